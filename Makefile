# The whole set-up on a fresh machine is `make demo` or `make test`.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP_RUN := $(VENV)/.installed-run
STAMP_DEV := $(VENV)/.installed-dev
export MUJOCO_GL ?= disable

.PHONY: demo test bench docs clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

# after installing, compile the numba kernels once (about 22 s of CPU) so that the first run starts warm
$(STAMP_RUN): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e .
	$(VENV)/bin/excavsim warmup
	touch $@

$(STAMP_DEV): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e ".[dev]"
	$(VENV)/bin/excavsim warmup
	touch $@ $(STAMP_RUN)

# one default trenching episode, headless, recorded for the Rerun viewer (`excavsim replay runs/demo.rrd`)
demo: $(STAMP_RUN)
	$(VENV)/bin/excavsim trench --record runs/demo.rrd

# the layer contracts of pyproject.toml (import-linter), then the tests on every core (pytest-xdist);
# the slow tier (campaigns, fits, whole studies: `-m slow`) runs only with EXCAVSIM_SLOW=1, as CI sets it
PYTEST_TIER := $(if $(EXCAVSIM_SLOW),,-m "not slow")
test: $(STAMP_DEV)
	$(VENV)/bin/lint-imports
	$(PY) -m pytest -q -n auto --dist loadscope $(PYTEST_TIER)

# the README's pictures (docs/images/): the demo episode in the headless Rerun viewer (needs Vulkan: Debian's
# mesa-vulkan-drivers without a GPU), the plan's figures and a campaign plot
.PHONY: pictures
pictures: $(STAMP_RUN)
	$(PY) scripts/make_pictures.py --out docs/images

# the documentation site (Sphinx + MyST + furo) from docs/, warnings as errors; needs the docs extra
STAMP_DOCS := $(VENV)/.installed-docs
$(STAMP_DOCS): pyproject.toml | $(STAMP_RUN)
	$(PY) -m pip install --quiet -e ".[docs]"
	touch $@

docs: $(STAMP_DOCS)
	$(VENV)/bin/sphinx-build -W --keep-going -b html docs docs/_build/html

bench: $(STAMP_RUN)
	$(VENV)/bin/excavsim bench

clean:
	rm -rf $(VENV) .pytest_cache build *.egg-info docs/_build docs/reference/_autosummary
