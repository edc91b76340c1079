"""Docs that cannot rot: README.md and docs/ are checked against the code.

- every ``excavsim ...`` command line in a shell code block is parsed by the real parser
  (``excavsim.cli.build_parser``), without running it: a renamed or removed option fails here;
- every ``configs/...`` path the text names exists, and each configuration file passes the check
  its use makes (``excavsim validate KIND FILE`` where validate knows the kind; the loader of the
  command that reads it otherwise);
- every Python block marked ``<!-- runnable -->`` (the line before its fence) runs without error.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import io
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from excavsim import cli, constants

ROOT = constants.REPO_ROOT
DOC_FILES = sorted([ROOT / "README.md"] + [p for p in (ROOT / "docs").rglob("*.md")
                                            if "_build" not in p.parts and "_autosummary" not in p.parts])
SHELL_LANGS = {"sh", "bash", "shell", "console", "shell-session", ""}  # "": a block without a language
RUNNABLE = "<!-- runnable -->"
CONFIG_PATH = re.compile(r"(?<![\w/.])configs/[\w./*-]*[\w*/]")


@dataclass(frozen=True)
class Block:
    """A fenced code block of a Markdown file: its language, text, where it starts, and its marker."""

    path: Path
    line: int
    lang: str
    code: str
    runnable: bool

    @property
    def where(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"


def code_blocks(path: Path) -> list[Block]:
    """The fenced code blocks of a Markdown file (``` fences; a block inside a list may be indented)."""
    blocks, lines = [], path.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        m = re.match(r"^\s*(`{3,})\s*\{?([\w-]*)\}?", lines[i])
        if not m:
            i += 1
            continue
        fence, lang, start = m.group(1), m.group(2).lower(), i
        body = []
        i += 1
        while i < len(lines) and not lines[i].strip().startswith(fence):
            body.append(lines[i])
            i += 1
        previous = next((lines[j].strip() for j in range(start - 1, -1, -1) if lines[j].strip()), "")
        blocks.append(Block(path, start + 1, lang, "\n".join(body), previous == RUNNABLE))
        i += 1
    return blocks


def excavsim_commands(block: Block) -> list[list[str]]:
    """The ``excavsim ...`` command lines of a shell block, as argument lists (comments, prompts and
    line continuations handled; ``.venv/bin/excavsim`` and ``python -m excavsim`` count too)."""
    text = re.sub(r"\\\n\s*", " ", block.code)
    commands = []
    for raw in text.splitlines():
        line = raw.strip()
        line = line[2:] if line.startswith("$ ") else line
        if not re.match(r"^(\S*/)?(excavsim|python3? -m excavsim|make)\b", line):
            continue  # not a command line (output, a listing): only lines that start with a command
        words = shlex.split(line, comments=True)
        for piece in _split_on_operators(words):
            if piece[:3] in (["python", "-m", "excavsim"], ["python3", "-m", "excavsim"]):
                piece = ["excavsim"] + piece[3:]
            if piece and (piece[0] == "excavsim" or piece[0].endswith("/excavsim")):
                commands.append(piece[1:])
    return commands


def _split_on_operators(words: list[str]) -> list[list[str]]:
    pieces, current = [], []
    for w in words:
        if w in ("&&", "||", ";", "|"):
            pieces.append(current)
            current = []
        else:
            current.append(w)
    pieces.append(current)
    return pieces


def _is_synopsis(argv: list[str]) -> bool:
    """A usage line (``load [--machine loader|shovel] [--out DIR]``) rather than a command."""
    return any(w.startswith("[") or w.endswith("]") or ("|" in w and not w.startswith("-"))
               or re.fullmatch(r"[A-Z][A-Z0-9_]*([.=][\w.]*)?|\.\.\.|…", w) for w in argv)


def check_synopsis(argv: list[str]) -> str | None:
    """A usage line names a real command, and every ``--option`` it shows is one of that command's."""
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    if argv and argv[0].startswith("-"):  # the program's own options (--version, --help)
        unknown = [w for w in argv if w.startswith("-") and w not in parser._option_string_actions]
        return f"excavsim: unrecognized arguments: {' '.join(unknown)}" if unknown else None
    if not argv or argv[0] not in sub.choices:
        return f"unknown command {argv[:1]} (the commands: {', '.join(sub.choices)})"
    known = set(sub.choices[argv[0]]._option_string_actions)
    named = {m for w in argv[1:] for m in re.findall(r"(?<![\w-])(--?[A-Za-z][\w-]*)", w)}
    unknown = sorted(named - known)
    return f"excavsim {argv[0]}: unrecognized arguments: {' '.join(unknown)}" if unknown else None


def check_command(argv: list[str]) -> str | None:
    """Parse ``argv`` (the words after ``excavsim``) with the real parser without running the command;
    returns None when it parses, else the parser's message. A usage line (with ``[...]`` and ``a|b``) is
    checked option by option instead."""
    if argv[:1] == ["[usage]"]:
        return check_synopsis(argv[1:])
    if _is_synopsis(argv):
        return check_synopsis(argv)
    parser = cli.build_parser()
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            args = parser.parse_args(argv)
    except SystemExit as exc:
        if exc.code in (0, None):  # --help, --version: a valid line
            return None
        return err.getvalue().strip().splitlines()[-1] if err.getvalue().strip() else f"exit {exc.code}"
    if not hasattr(args, "func"):
        return "no command given"
    return None


def all_blocks() -> list[Block]:
    return [b for f in DOC_FILES for b in code_blocks(f)]


INLINE = re.compile(r"(?<!`)`((?:\S*/)?excavsim [^`]+)`(?!`)")


def inline_commands() -> list[tuple[str, list[str]]]:
    """The ``excavsim ...`` code spans of the prose (tables, sentences), outside the code blocks.

    A span mentions a command (``excavsim replay``, ``excavsim campaign --ray``) more often than it
    gives a whole command line, so spans are checked as usage lines: the command exists and has
    every option the span names."""
    found = []
    for f in DOC_FILES:
        fenced = False
        for n, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1):
            if line.lstrip().startswith("```"):
                fenced = not fenced
            if fenced:
                continue
            for m in INLINE.finditer(line):
                try:
                    words = shlex.split(m.group(1).replace("\\|", "|"))
                except ValueError:
                    found.append((f"{f.relative_to(ROOT)}:{n}", ["<unparseable>", m.group(1)]))
                    continue
                if words[1:] and not re.fullmatch(r"[A-Z_]+|\.\.\.|…", words[1]):  # `excavsim COMMAND`
                    found.append((f"{f.relative_to(ROOT)}:{n}", ["[usage]"] + words[1:]))
    return found


def all_commands() -> list[tuple[str, list[str]]]:
    """Every ``excavsim ...`` command of the README and docs: the lines of shell blocks and the code spans."""
    blocks = [(b.where, argv) for b in all_blocks() if b.lang in SHELL_LANGS for argv in excavsim_commands(b)]
    return blocks + inline_commands()


# -- configuration paths ---------------------------------------------------------------------------
def named_config_paths() -> dict[str, list[str]]:
    """Every ``configs/...`` path the README and docs name, with where each is named."""
    found: dict[str, list[str]] = {}
    for f in DOC_FILES:
        for n, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1):
            for m in CONFIG_PATH.finditer(line):
                found.setdefault(m.group(0), []).append(f"{f.relative_to(ROOT)}:{n}")
    return found


def check_config_path(named: str) -> list[str]:
    """The problems of one named path: missing, or a file that fails its check."""
    paths = sorted(ROOT.glob(named)) if "*" in named else [ROOT / named]
    if not paths or not all(p.exists() for p in paths):
        return [f"{named}: no such file or directory"]
    return [p for path in paths if path.is_file() and path.suffix in (".yaml", ".yml")
            for p in _check_file(path)]


@functools.lru_cache(maxsize=None)
def _check_file(path: Path) -> tuple[str, ...]:
    """The problems of one configuration file (each file is checked once, however often it is named):
    ``excavsim validate FILE``, which tells the file's kind from its place or its fields."""
    rel = path.relative_to(ROOT).as_posix()
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = cli.main(["validate", str(path)])
    return () if status == 0 else (f"{rel}: excavsim validate fails: {err.getvalue().strip()}",)


# -- tests -----------------------------------------------------------------------------------------
def test_the_docs_name_commands_and_configs():
    """The checks below check something: the docs hold many commands and configuration paths."""
    assert len(DOC_FILES) >= 30, DOC_FILES
    assert len(all_commands()) >= 100
    assert len(named_config_paths()) >= 15
    assert any(b.runnable and b.lang == "python" for b in all_blocks())


def test_every_excavsim_command_in_the_docs_parses(monkeypatch):
    """Each ``excavsim ...`` line of a shell block parses with the real parser (paths relative to the
    repository, as the docs write them)."""
    monkeypatch.chdir(ROOT)
    bad = [f"{where}: excavsim {shlex.join(argv)}\n    {msg}"
           for where, argv in all_commands() if (msg := check_command(argv))]
    assert not bad, "commands in the docs the parser rejects:\n" + "\n".join(bad)


def test_a_renamed_option_is_reported(monkeypatch):
    """The checker fails a docs command whose option was renamed: the same check, on a line of the docs
    with one option changed, reports the unknown option by name."""
    monkeypatch.chdir(ROOT)
    where, argv = next((w, a) for w, a in all_commands() if "--dig-budget" in a)
    assert check_command(argv) is None, where
    renamed = [("--dig-limit" if a == "--dig-budget" else a) for a in argv]
    message = check_command(renamed)
    assert message is not None and "--dig-limit" in message, message
    # a parser whose option was renamed rejects the docs' unchanged line the same way
    real = cli.build_parser

    def renamed_parser():
        parser = real()
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        trench = sub.choices[argv[0]]
        action = next(a for a in trench._actions if "--dig-budget" in a.option_strings)
        action.option_strings = ["--digs"]
        trench._option_string_actions.pop("--dig-budget")
        trench._option_string_actions["--digs"] = action
        return parser

    monkeypatch.setattr(cli, "build_parser", renamed_parser)
    message = check_command(argv)
    assert message is not None and "--dig-budget" in message, message
    # and so does a usage line of the prose (a code span) that shows the option
    usage = next(a for _, a in inline_commands() if a[1:2] == [argv[0]] and any("--dig-budget" in w for w in a))
    message = check_command(usage)
    assert message is not None and "--dig-budget" in message, message


def test_a_missing_config_path_is_reported():
    """The path check reports a file the docs name that does not exist, and an invalid one."""
    assert check_config_path("configs/trenches/no_such_trench.yaml") == [
        "configs/trenches/no_such_trench.yaml: no such file or directory"]


def test_an_invalid_config_named_by_the_docs_is_reported(tmp_path, monkeypatch):
    """A goal file that `excavsim validate` rejects is reported with validate's message."""
    goal_dir = tmp_path / "configs" / "trenches"
    goal_dir.mkdir(parents=True)
    good = (ROOT / "configs/trenches/small.yaml").read_text()
    (goal_dir / "small.yaml").write_text(good)
    (goal_dir / "broken.yaml").write_text(good + "\nno_such_field: 1\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    assert check_config_path("configs/trenches/small.yaml") == []
    problems = check_config_path("configs/trenches/broken.yaml")
    assert len(problems) == 1 and "validate fails" in problems[0] and "no_such_field" in problems[0], problems


@pytest.mark.parametrize("named", sorted(named_config_paths()))
def test_every_named_config_path_exists_and_passes_its_check(named):
    problems = check_config_path(named)
    assert not problems, f"named at {', '.join(named_config_paths()[named][:3])}:\n" + "\n".join(problems)


RUNNABLE_BLOCKS = [b for b in all_blocks() if b.runnable]


@pytest.mark.parametrize("block", RUNNABLE_BLOCKS, ids=[b.where for b in RUNNABLE_BLOCKS])
def test_runnable_python_blocks_run(block, tmp_path):
    """A block marked ``<!-- runnable -->`` runs as written in a fresh interpreter, in a scratch directory."""
    assert block.lang == "python", f"{block.where}: only python blocks can be marked runnable"
    out = subprocess.run([sys.executable, "-c", block.code], cwd=tmp_path, capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, f"{block.where} failed:\n{out.stderr[-3000:]}"


def test_the_readme_is_a_front_door():
    """The README stays short (the issue's bound: 250 lines) and its command table has a row for every
    command the parser knows, and no row for one it does not."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 250, f"README.md has {len(text.splitlines())} lines; move detail to docs/"
    parser = cli.build_parser()
    commands = set(next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices)
    rows = set(re.findall(r"^\| `excavsim ([a-z-]+)`", text, re.M))
    assert rows == commands, f"missing rows: {sorted(commands - rows)}; rows of no command: {sorted(rows - commands)}"
