"""The records the compiled soil kernel reads and writes: numpy structured dtypes with named fields.

:func:`excavsim.world.kernels.soil_step` takes the grid's and the bucket's geometry, the wedge table,
its parameters, its state and its output as these records and reads and writes them by field name
(numba compiles a field access to a load at a fixed offset, and a sub-array field to a view). A new
term of the model is a field here, set in :class:`~excavsim.world.soil.SoilModel`, and used in the
kernel. Single records (the grid, the bucket, the parameters, the state, the output) travel as
arrays of shape ``(1,)``, per-sample records (the bucket surface, the wedge table) as ``(n,)``.

Frames: "body" is the bucket body frame, "world" MuJoCo's world frame. 3-vector fields are ``(3,)``
float64 sub-arrays. The records are aligned (``align=True``) and the output's fields are all 8 bytes
wide, so that a step's output is copied and read as plain float64 (:func:`float64_slots`).
"""

from __future__ import annotations

import numpy as np

_F8 = np.float64
_V3 = (3,)  # the shape of a 3-vector field

GRID = np.dtype([
    ("x0_m", _F8),
    ("y0_m", _F8),
    ("cell_m", _F8),
    ("z0_m", _F8),
], align=True)
"""Where the terrain grid lies (:class:`~excavsim.world.terrain.SoilGrid`; ``heights[row, col]``).

Fields:
    x0_m, y0_m: world position of sample (0, 0) [m]; columns run along x, rows along y.
    cell_m: sample spacing [m].
    z0_m: world height of the box floor, height 0 of the grid [m].
"""

BUCKET = np.dtype([
    ("body_id", np.int64),
    ("tip_site_id", np.int64),
    ("width_m", _F8),
    ("edge_ends_m", _F8, (2, 3)),
    ("load_centroid_m", _F8, _V3),
], align=True)
"""The bucket's fixed geometry besides its samples (:class:`~excavsim.world.bucket.BucketGeometry`).

Fields:
    body_id: MuJoCo id of the bucket body (its ``xpos``, ``xmat``, ``xipos`` rows are read).
    tip_site_id: MuJoCo id of the ``bucket_tip`` site, whose frame gives the tip axes ``x_t``, ``z_t``.
    width_m: inner width of the bucket, the width that cuts [m].
    edge_ends_m: (2, 3) the two ends of the cutting edge, half a width sample beyond the outer edge
        samples, body frame [m].
    load_centroid_m: where the load's weight acts, the centroid of the bucket interior, body frame [m].
"""

SURFACE_SAMPLE = np.dtype([
    ("point_m", _F8, _V3),
    ("normal", _F8, _V3),
    ("area_m2", _F8),
    ("active", np.bool_),
], align=True)
"""One sample of the bucket's outer surface, where bearing pressure and friction act.

Fields:
    point_m: the sample point, body frame [m].
    normal: outward unit normal of the outer surface there, body frame.
    area_m2: surface area the sample stands for [m^2].
    active: whether it bears on the soil; False on the cutting face near the edge, whose resistance
        the wedge model already accounts for.
"""

WEDGE_ROW = np.dtype([
    ("beta_rad", _F8),
    ("n_gamma", _F8),
    ("n_c", _F8),
    ("n_a", _F8),
    ("denominator", _F8),
    ("n_acc", _F8),
], align=True)
"""One rake of the wedge table (:class:`~excavsim.mechanics.wedge.WedgeTable`), row ``i`` at rake
``table_rake0_rad + i * table_rake_step_rad`` (:data:`PARAMS`); linear interpolation between rows.

Fields:
    beta_rad: critical failure angle beta [rad].
    n_gamma, n_c, n_a: the N factors of weight, cohesion and adhesion (eqs. 5, 8) [-].
    denominator: the denominator D of eq. 5, which divides the surcharge's weight [-].
    n_acc: the acceleration factor of the dynamic earthmoving equation at beta
        (:func:`~excavsim.mechanics.wedge_inertia.acceleration_factor`, McKyes 1985) [-].
"""

PARAMS = np.dtype([
    ("gamma_g_n_m3", _F8),
    ("density_kg_m3", _F8),
    ("cohesion_pa", _F8),
    ("adhesion_pa", _F8),
    ("sin_delta", _F8),
    ("cos_delta", _F8),
    ("mu", _F8),
    ("rake_min_rad", _F8),
    ("table_rake0_rad", _F8),
    ("table_rake_step_rad", _F8),
    ("cut_stiffness_n_per_m", _F8),
    ("capacity_m3", _F8),
    ("cohesion_rate_per_decade", _F8),
    ("rate_reference_speed_m_s", _F8),
    ("brittleness_index", _F8),
    ("k_rest_pa_per_m", _F8),
    ("q_ult0_pa", _F8),
    ("q_ult_slope_pa_per_m", _F8),
    ("k_mob_pa_per_m", _F8),
    ("friction_velocity_m_s", _F8),
    ("friction_mass_kg", _F8),
    ("rock_stiffness_n_per_m", _F8),
    ("load_surcharge", _F8),
], align=True)
"""The constants of the bucket-soil interaction over an episode (see :mod:`excavsim.world.soil`).

Fields:
    gamma_g_n_m3: unit weight of the soil, density times gravity [N/m^3].
    density_kg_m3: the soil's density, the mass that the dynamic earthmoving equation accelerates [kg/m^3].
    cohesion_pa, adhesion_pa: the soil's cohesion c and the soil-tool adhesion c_a [Pa].
    sin_delta, cos_delta: of the soil-tool friction angle delta, which sets the wedge force's
        direction (eq. 8) [-].
    mu: soil-tool friction coefficient ``tan(delta)`` of the outer surface [-].
    rake_min_rad: the wedge factors are held at this rake below it [rad].
    table_rake0_rad, table_rake_step_rad: the wedge table's uniform rake grid, first rake and
        spacing [rad].
    cut_stiffness_n_per_m: how fast the cutting force builds with the edge's travel into soil [N/m].
    capacity_m3: heaped capacity of the bucket; cut soil beyond it spills ahead [m^3].
    cohesion_rate_per_decade: truth term, the rate effect on cohesion and adhesion: their gain per
        tenfold increase of the edge's advance speed above ``rate_reference_speed_m_s`` [-].
    rate_reference_speed_m_s: the advance speed at which the preset's cohesion holds [m/s].
    brittleness_index: truth term, the share of the failure force lost when the wedge fails along
        its critical plane (post-peak softening; Bishop 1967), the drop of each saw-tooth [-].
    k_rest_pa_per_m: at-rest earth pressure per metre of depth, ``K0 gamma g`` [Pa/m].
    q_ult0_pa, q_ult_slope_pa_per_m: bearing capacity at the surface and its growth with depth,
        ``q_ult = q_ult0 + slope p`` [Pa], [Pa/m].
    k_mob_pa_per_m: bearing pressure mobilized per metre the surface moves into the soil [Pa/m].
    friction_velocity_m_s: slip speed below which friction is regularized, at least [m/s].
    friction_mass_kg: lower bound on the bucket's effective mass that keeps the friction's implied
        damping stable over a control step [kg].
    rock_stiffness_n_per_m: contact stiffness of buried rocks on the edge samples [N/m].
    load_surcharge: 1 if the bucket's load bears on the wedge as surcharge (a share ``load /
        capacity_m3`` of it, Singh 1995 eq. 7, Fig. 57), 0 if only the soil heaped ahead does [-].
"""

STATE = np.dtype([
    ("prev_edge_ends_m", _F8, (2, 3)),
    ("prev_edge_centre_m", _F8, _V3),
    ("cut_force_n", _F8),
    ("mobilised", _F8),
    ("load_m3", _F8),
    ("has_prev", np.bool_),
    ("failed", np.bool_),
], align=True)
"""What the interaction carries from one control step to the next (besides the bearing pressures).

Fields:
    prev_edge_ends_m: (2, 3) the cutting edge's two ends at the last step, world frame [m].
    prev_edge_centre_m: the centre of the edge samples at the last step, world frame [m].
    cut_force_n: the elastic cutting force built up in the wedge ahead of the edge [N].
    mobilised: after the wedge's first failure, the force carried by the new wedge as a share of
        the nominal (strength 1) failure force at the present depth [-].
    load_m3: soil in the bucket [m^3].
    has_prev: False until the first step has set the previous edge.
    failed: True once the wedge ahead has failed since the edge entered the soil (the failure
        cycle of the saw-tooth runs from then on).
"""

OUT = np.dtype([
    ("depth_m", _F8),
    ("rake_rad", _F8),
    ("cutting_speed_m_s", _F8),
    ("advance_speed_m_s", _F8),
    ("wedge_failure_force_n", _F8),
    ("inertial_force_n", _F8),
    ("wedge_failed", _F8),
    ("wedge_length_m", _F8),
    ("cutting_force_n", _F8, _V3),
    ("bearing_force_n", _F8, _V3),
    ("rock_force_n", _F8, _V3),
    ("force_n", _F8, _V3),
    ("torque_nm", _F8, _V3),
    ("cut_volume_m3", _F8),
    ("taken_volume_m3", _F8),
    ("max_penetration_m", _F8),
    ("ahead", _F8, _V3),
    ("edge_centre_m", _F8, _V3),
    ("load_weight_z_n", _F8),
    ("window", np.int64, (4,)),
], align=True)
"""What one control step of the interaction produces (forces on the bucket, world frame).

Fields:
    depth_m: mean depth of the edge samples below the surface just ahead of them [m].
    rake_rad: rake of the blade [rad].
    cutting_speed_m_s: the edge's speed into the soil, against the wedge force [m/s].
    advance_speed_m_s: the edge's horizontal advance along ``ahead``, the speed at which soil
        enters the wedge (dynamic earthmoving equation, rate effect) [m/s].
    wedge_failure_force_n: failure force of the wedge with the truth terms [N].
    inertial_force_n: the part of it that accelerates the soil entering the wedge [N].
    wedge_failed: 1.0 if the wedge failed along its critical plane this step, else 0.0.
    wedge_length_m: length of the failure wedge ahead of the edge, ``d (cot rho + cot beta)`` [m]
        (0 out of the soil).
    cutting_force_n: the wedge's force on the bucket [N].
    bearing_force_n: bearing pressure and friction on the outer surface [N].
    rock_force_n: the rocks' push on the edge samples [N].
    force_n: the total, cutting + bearing + rocks + the load's weight [N].
    torque_nm: the total moment about the bucket's centre of mass [N m].
    cut_volume_m3: soil cut from the terrain this step [m^3].
    taken_volume_m3: the part of it that entered the bucket; the rest spills ahead [m^3].
    max_penetration_m: deepest outer-surface sample below the surface [m].
    ahead: horizontal unit vector along which the blade pushes the soil, where spill lands.
    edge_centre_m: centre of the edge samples [m].
    load_weight_z_n: vertical component of the load's weight (negative, downwards) [N].
    window: the rows and columns changed by the cut, ``[r0, r1, c0, c1)``; ``r0 > r1`` when none.
"""


def filled(dtype: np.dtype, n: int = 1, **fields) -> np.ndarray:
    """``n`` records of ``dtype`` (a ``(n,)`` array) with every field set from ``fields``.

    A field's value is broadcast over the records (a scalar, or a 3-vector for a 3-vector field) or
    gives one per record (shape ``(n, ...)``). Every field must be given, so that a field added to a
    dtype cannot be left at zero by mistake.

    Raises:
        TypeError: ``fields`` miss a field of ``dtype`` or name one it does not have.
    """
    missing = [name for name in dtype.names if name not in fields]
    unknown = [name for name in fields if name not in dtype.names]
    if missing or unknown:
        raise TypeError(f"record fields: missing {missing}, unknown {unknown}; the fields are {list(dtype.names)}")
    out = np.zeros(n, dtype)
    for name, value in fields.items():
        out[name] = value
    return out


def float64_slots(dtype: np.dtype) -> dict[str, int | slice]:
    """Where each float64 field of ``dtype`` lies in a record's float64 view (``rec.view(np.float64)``).

    A plain float64 copy of a record is much cheaper than numpy's field-by-field copy of a
    structured array; these are the positions to read it at: an index for a scalar field, a slice
    for a sub-array field (flattened). Fields of other types are left out.

    Raises:
        TypeError: ``dtype`` has no float64 view (its size or a float64 field's offset is not a
            multiple of 8 bytes).
    """
    if dtype.itemsize % 8:
        raise TypeError(f"a record of {dtype.itemsize} bytes has no float64 view; use align=True")
    slots: dict[str, int | slice] = {}
    for name in dtype.names:
        field, offset = dtype.fields[name][:2]
        if field.base != np.float64:
            continue
        if offset % 8:
            raise TypeError(f"field {name!r} at byte {offset} is not on a float64 boundary; use align=True")
        start, size = offset // 8, int(np.prod(field.shape, dtype=int))
        slots[name] = start if field.shape == () else slice(start, start + size)
    return slots


DIMAIO_PARAMS = np.dtype([
    ("b_t0", _F8),
    ("b_n0", _F8),
    ("b_a0", _F8),
    ("k", _F8),
    ("k_a", _F8),
    ("t_rt", _F8),
    ("t_rn", _F8),
    ("t_ra", _F8),
    ("shear_s", _F8),
    ("eps", _F8),
    ("mu", _F8),
    ("rho_g", _F8),
    ("s_bucket", _F8),
    ("width", _F8),
    ("v_eps", _F8),
], align=True)
"""The constants of DiMaio's bucket-ground model (:mod:`excavsim.world.dimaio`; DiMaio 1998 §5.2).

Fields:
    b_t0, b_n0: viscous friction per metre of penetration along and normal to the cutting surface,
        eq. 5.43 [N s/m^2].
    b_a0: rotational viscous friction per metre of penetration, eq. 5.42 [N s].
    k, k_a: translational and angular soil stiffness, eq. 5.44 [N/m], [N m/rad].
    t_rt, t_rn: relaxation time constants of the stiffness centre along and normal to the cutting
        surface, eq. 5.46 [s]; t_ra: that of the orientation centre (assumed) [s].
    shear_s: the soil characteristic S of the shear threshold ``S w d_p``, eq. 5.45 [Pa].
    eps: the load's accumulation (churning) force per cubic metre of load, eq. 5.47 [N/m^3].
    mu: the soil-bucket Coulomb friction coefficient, eq. 5.49 [-].
    rho_g: the soil's unit weight, rho g of eq. 5.47 [N/m^3].
    s_bucket: length of the flat cutting surface; the load acts at its centre [m].
    width: bucket width w [m].
    v_eps: tangential speed below which the Coulomb direction v_t/|v_t| is regularized (assumed) [m/s].
"""

DIMAIO_STATE = np.dtype([
    ("offset_rz", _F8, (2,)),
    ("alpha_rel", _F8),
    ("prev_t_rz", _F8, (2,)),
    ("has_prev_t", np.bool_),
], align=True)
"""What DiMaio's model carries from one step to the next (in the arm plane, coordinates (r, z)).

Fields:
    offset_rz: the stiffness centre relative to the cutting edge, ``(r_c - r, z_c - z)`` [m].
    alpha_rel: the bucket's angle from the orientation centre, ``alpha - alpha_c`` [rad].
    prev_t_rz: the cutting surface's tangent at the last step, whose turn gives the angular rate.
    has_prev_t: False until the first step.
"""

DIMAIO_OUT = np.dtype([
    ("viscous_tn", _F8, (2,)),
    ("stiffness_tn", _F8, (2,)),
    ("coulomb_t", _F8),
    ("load_rz", _F8, (2,)),
    ("tip_force_rz", _F8, (2,)),
    ("force_rz", _F8, (2,)),
    ("force_tn", _F8, (2,)),
    ("torque_pure", _F8),
    ("torque_tip", _F8),
    ("threshold_n", _F8),
    ("sheared", _F8),
    ("sp_m", _F8),
    ("dp_m", _F8),
    ("v_t", _F8),
    ("v_n", _F8),
], align=True)
"""One step of DiMaio's model, in the arm plane (forces on the bucket; "tn": along the cutting
surface's tangent t and normal n, "rz": radial and vertical).

Fields:
    viscous_tn: eqs. 5.41-5.43 [N]; stiffness_tn: eq. 5.44 after eq. 5.45 [N];
    coulomb_t: eq. 5.49, tangential [N]; load_rz: eq. 5.47, accumulation and weight [N].
    tip_force_rz: viscous + stiffness + Coulomb, which act at the cutting edge [N].
    force_rz, force_tn: the total, load included [N].
    torque_pure: the orientation torques of eqs. 5.42 and 5.44 [N m], about the across axis (a
        positive torque turns r towards z); torque_tip: the total moment about the cutting edge,
        the load's arm of eq. 5.47 included [N m].
    threshold_n: the shear threshold ``S w d_p`` of eq. 5.45 [N]; sheared: 1.0 if the soil sheared.
    sp_m, dp_m: the penetration and the distance from the edge to the surface along the normal [m].
    v_t, v_n: the edge's velocity along t and n [m/s].
"""
