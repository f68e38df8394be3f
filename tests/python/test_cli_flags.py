"""One CLI family (docs/tools.md): every tool is a `pleat-*` console script, and every console script's argparse
parser follows the same conventions (docs/tools.md). The parsers are the ones each `main` really builds: the test
stops `parse_args` and walks the parser it was called on, subcommands included."""
import argparse
import ast
import importlib
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PYPROJECT = REPO / "tools" / "pyproject.toml"
SCRIPTS = tomllib.loads(PYPROJECT.read_text())["project"]["scripts"]
OPTIONAL = {"torch"}          # extras a module may need at import (pip install 'pleat-tools[train]')


class _Parsed(BaseException):
    """Raised instead of parsing (a BaseException, so that pleat.cli.command does not turn it into an error line)."""

    def __init__(self, parser):
        super().__init__()
        self.parser = parser


def _parser_of(entry, monkeypatch):
    module, func = entry.split(":")
    try:
        main = getattr(importlib.import_module(module), func)
    except ImportError as exc:
        if exc.name in OPTIONAL:
            pytest.skip(f"{module} needs {exc.name}")
        raise

    def stop(self, *args, **kwargs):
        raise _Parsed(self)
    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", stop)
    with pytest.raises(_Parsed) as got:
        main([])
    return main, got.value.parser


def _leaves(parser, path=()):
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield " ".join(path), parser
    for action in subs:
        for name, child in action.choices.items():
            yield from _leaves(child, path + (name,))


def _options(parser):
    return [a for a in parser._actions if a.option_strings and not isinstance(a, argparse._HelpAction)]


def test_every_runnable_tool_module_is_a_console_script():
    """A module with a `main` run under `if __name__ == "__main__"` is a tool: it must be a pleat-* script."""
    targets = {entry.split(":")[0] for entry in SCRIPTS.values()}
    runnable = set()
    for path in (REPO / "tools" / "pleat").rglob("*.py"):
        tree = ast.parse(path.read_text())
        has_main = any(isinstance(n, ast.FunctionDef) and n.name == "main" for n in tree.body)
        runs = any(isinstance(n, ast.If) and "__main__" in ast.unparse(n.test) for n in tree.body)
        if has_main and runs:
            runnable.add(".".join(path.relative_to(REPO / "tools").with_suffix("").parts))
    assert runnable - targets == set(), "tools only reachable with python -m"
    assert all(name.startswith("pleat-") for name in SCRIPTS)


@pytest.mark.parametrize("script", sorted(SCRIPTS))
def test_console_script_flags_follow_the_conventions(script, monkeypatch):
    main, parser = _parser_of(SCRIPTS[script], monkeypatch)
    assert getattr(main, "prog", None) == script, "main is wrapped by pleat.cli.command (one error line, exit 1)"
    assert parser.prog == script
    problems = []
    for where, leaf in _leaves(parser):
        at = f"{script} {where}".strip()
        options = _options(leaf)
        by_flag = {flag: a for a in options for flag in a.option_strings}
        for action in leaf._actions:
            if isinstance(action, argparse._HelpAction) or isinstance(action, argparse._SubParsersAction):
                continue
            if action.help is argparse.SUPPRESS:
                continue            # internal options (the cross-check's subprocess entry points) stay hidden
            if not (action.help or "").strip():
                problems.append(f"{at}: {'/'.join(action.option_strings) or action.dest} has no help text")
        for a in options:
            for flag in a.option_strings:
                if flag.startswith("--") and not re.fullmatch(r"--[a-z0-9]+(-[a-z0-9]+)*", flag):
                    problems.append(f"{at}: {flag} is not lower-case-with-dashes")
        quiet = by_flag.get("--quiet")
        if quiet is None or quiet.dest != "quiet" or not isinstance(quiet, argparse._StoreTrueAction):
            problems.append(f"{at}: no --quiet (store_true, dest quiet)")
        old = by_flag.get("--no-progress")
        if old is not None and (old.dest != "quiet" or "deprecated alias of --quiet" not in old.help):
            problems.append(f"{at}: --no-progress must be the deprecated alias of --quiet")
        for legacy in ("--output", "-o"):
            if legacy in by_flag and "--out" not in by_flag[legacy].option_strings:
                problems.append(f"{at}: {legacy} is not an alias of --out")
        out = by_flag.get("--out")
        if out is not None and not re.match(r"output (file|folder)\b", out.help or ""):
            problems.append(f"{at}: --out help must say 'output file' or 'output folder', got {out.help!r}")
        body = by_flag.get("--body")
        if body is not None and "body npz" not in (body.help or ""):
            problems.append(f"{at}: --body help must say it is a body npz")
    assert not problems, "\n".join(problems)


def test_no_progress_still_works_as_quiet(monkeypatch):
    main, parser = _parser_of(SCRIPTS["pleat-eval"], monkeypatch)
    monkeypatch.undo()
    args = parser.parse_args(["--asset", "a.pleat", "--motion", "m", "--json", "r.json", "--no-progress"])
    assert args.quiet and args.json == "r.json", "--json (older name of --out) and --no-progress still parse"


def test_the_repository_is_looked_up_in_one_place(tmp_path):
    """Only pleat.paths derives locations from the package's own path; PLEAT_ROOT moves every default with it."""
    for path in (REPO / "tools" / "pleat").rglob("*.py"):
        if path.name != "paths.py":
            assert not re.search(r"__file__\)?\.resolve\(\)\.parents", path.read_text()), path
    code = ("from pleat import REPO_ROOT, paths; from pleat.body.model import default_body_path; "
            "from pleat.motion.loaders import motion_dirs; from pleat.sim import scene; "
            "print(REPO_ROOT, default_body_path(), paths.GARMENTS_DIR, motion_dirs()[-1], sep='|')")
    env = {k: v for k, v in os.environ.items() if k != "PLEAT_MOTION_DIR"}
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=60,
                         env=dict(env, PLEAT_ROOT=str(tmp_path)))
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip().split("|") == [str(tmp_path), str(tmp_path / "assets" / "body.npz"),
                                             str(tmp_path / "data" / "garments"), str(tmp_path / "data" / "motion")]
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=60,
                         env={k: v for k, v in env.items() if k != "PLEAT_ROOT"})
    assert run.stdout.split("|")[0] == str(REPO), "without PLEAT_ROOT: the checkout the package comes from"
