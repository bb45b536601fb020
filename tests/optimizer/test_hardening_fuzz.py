"""Fuzzer of the command line: hostile configuration files, ``--set`` overrides and options, each asserted to

* end with a documented exit status (0 ok, 2 bad input, 3 infeasible, 4 a stage failed; docs/reference/errors.md),
* print no traceback, and for bad input one ``error:`` line naming the offending key, option or file,
* leave no partial output: nothing at all in the output folder unless the command succeeded (0 or 3),
  and never a temporary file.

The heaviest hostile inputs are also run in a fresh child process whose own peak memory must stay within
:data:`MEGABYTES` of an idle child's (:func:`test_the_heaviest_inputs_stay_within_the_memory_bound`): measured in
the test process itself, a lifetime peak that an earlier test raised would hide any growth.

Cases: a corpus of every class of hostile input (files x commands, output locations, options), hypothesis over
``--set`` keys and values and over whole YAML documents, damaged campaign stores (a real store's bytes
truncated, overwritten or zeroed; its values and tables changed by SQL) against every command that reads a
run directory, and a few real subprocesses. Run-directory locks, signals, scheduler refusals and full disks
need real processes, a scheduler or a file system: ``tests/optimizer/campaign/test_concurrency.py``,
``test_signals.py``, ``test_cluster_refusal.py`` and ``tests/optimizer/test_half_written_outputs.py``. Commands are run
in-process through ``optimizer.cli.main``; ``mesh`` and ``evaluate`` only with inputs refused before any
stage (the fuzzer never meshes or solves). The fast tier runs about 260 cases in about 12 s; ``slow``
multiplies the hypothesis examples and adds the subprocesses.
"""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from optimizer.cli import main

ROOT = Path(__file__).parents[2]
QUICKSTART = str(ROOT / "optimizer" / "campaign" / "quickstart.yaml")
#: Exit statuses a command may end with (docs/reference/errors.md).
DOCUMENTED = {0, 2, 3, 4}
#: Bound on how much one command may raise a fresh process's peak memory above an idle one's, MB.
MEGABYTES = 500
FAST = settings(max_examples=30, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
SLOW = settings(FAST, max_examples=300)


@dataclass
class Outcome:
    code: int
    out: str
    err: str


def run_cli(argv: list[str], cwd: Path) -> Outcome:
    """``millfoil ARGV`` in-process in ``cwd``: exit status (argparse's SystemExit included), stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(cwd), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 2
    return Outcome(code, out.getvalue(), err.getvalue())


def check(outcome: Outcome, cwd: Path, named: tuple[str, ...] = (), inputs: tuple[str, ...] = ()) -> None:
    """The fuzzer's assertions for one case run in ``cwd`` (``inputs``: files there before the run)."""
    context = f"exit {outcome.code}\nstderr: {outcome.err[-2000:]}"
    assert outcome.code in DOCUMENTED, context
    assert "Traceback" not in outcome.err and "Traceback" not in outcome.out, context
    left = sorted(str(p.relative_to(cwd)) for p in cwd.rglob("*") if p.is_file() and p.name not in inputs)
    assert not [p for p in left if ".partial" in p or "millfoil-probe" in p], left
    if outcome.code in (2, 4):
        assert left == [], (context, left)
    if outcome.code == 2:
        errors = [line for line in outcome.err.splitlines() if "error:" in line]
        assert len(errors) == 1 and len(errors[0]) < 1500, context
        if named:
            assert any(n in errors[0] for n in named), (named, context)


def case(argv: list[str], files: dict[str, str | bytes] | None = None, named: tuple[str, ...] = ()) -> Outcome:
    """Run one case in a fresh folder holding ``files``; check it; return its outcome."""
    with tempfile.TemporaryDirectory() as tmp:
        cwd = Path(tmp)
        for name, text in (files or {}).items():
            (cwd / name).write_bytes(text if isinstance(text, bytes) else text.encode())
        outcome = run_cli(argv, cwd)
        check(outcome, cwd, named, tuple(files or ()))
        return outcome


# --------------------------------------------------------------------------------------------- corpus
def _bomb(levels: int) -> str:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, levels)]
    return "\n".join(lines) + f"\nblade:\n  parameters:\n    alpha: *a{levels - 1}\n"


#: Hostile configuration files: name -> (content, a text the message must hold).
FILES: dict[str, tuple[str | bytes, str]] = {
    "bomb": (_bomb(9), "expands to more than"),
    "bomb-deep": (_bomb(40), "c.yaml"),
    "recursive": ("blade: &b {parameters: *b}\n", "recursive alias"),
    "duplicate": ("blade:\n  parameters:\n    alpha: 20\n    alpha: 25\n", "duplicate key 'alpha'"),
    "duplicate-section": ("flow: {speed: 1}\nflow: {speed: 2}\n", "duplicate key 'flow'"),
    "boolean": ("blade:\n  parameters:\n    alpha: yes\n", "blade.parameters.alpha"),
    "boolean-flow": ("flow:\n  density: false\n", "flow.density"),
    "empty": ("", "is empty"),
    "comment": ("# nothing\n", "is empty"),
    "binary": (bytes(range(256)) * 4, "not a UTF-8 text file"),
    "latin1": ("blade:\n  mode: désign\n".encode("latin-1"), "not a UTF-8 text file"),
    "nul": (b"blade: {}\x00", "unacceptable character"),
    "deep": ("a: " + "[" * 100 + "]" * 100 + "\n", "nested more than"),
    "digits": ("blade:\n  parameters:\n    alpha: " + "1" * 5000 + "\n", "a number of 5000 characters"),
    "tag": ("blade: !!python/object/apply:os.system [ls]\n", "not valid YAML"),
    "documents": ("blade: {}\n---\nflow: {}\n", "not valid YAML"),
    "list": ("- blade\n- mesh\n", "must be a YAML mapping"),
    "scalar": ("just text\n", "must be a YAML mapping"),
    "unknown-section": ("meshing: {level: fine}\n", "unknown key 'meshing'"),
    "unclosed": ("blade: {mode: design\n", "not valid YAML"),
    "tab": ("blade:\n\tmode: design\n", "not valid YAML"),
    "huge-L": ("blade:\n  parameters: {L: 1.0e+6}\n", "'L'"),
    "inf": ("flow:\n  speed: .inf\n", "flow.speed"),
    "nan-param": ("blade:\n  parameters: {alpha: .nan}\n", "blade.parameters.alpha"),
    "huge-int": ("solver:\n  max_iter: 1" + "0" * 400 + "\n", "a number of 401 characters"),
    "float-as-int": ("solver:\n  max_iter: 1.5\n", "solver.max_iter"),
    "long-string": ("blade:\n  mode: " + "x" * 100_000 + "\n", "blade.mode"),
    "many-keys": ("blade:\n  parameters:\n" + "".join(f"    k{i}: {i}\n" for i in range(300)), "unknown parameter"),
}
COMMANDS = (["profile"], ["space"], ["check"], ["mesh", "--level", "coarse"], ["evaluate", "--level", "coarse"])


@pytest.mark.parametrize("name", list(FILES))
@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: c[0])
def test_hostile_files(command, name):
    text, message = FILES[name]
    if command == ["check"] and name == "unknown-section":
        message = "c.yaml"                          # a campaign has its own sections and space
    outcome = case([*command, "c.yaml"], {"c.yaml": text}, named=(message,))
    # space and check read the optimisation space, not one blade: its parameter values are not built
    assert outcome.code == (0 if name in ("huge-L", "many-keys") and command[0] in ("space", "check") else 2)


#: Output locations refused before any stage: (argv, the option the message names).
OUTPUTS = [
    (["profile", "--out", "missing/p.csv"], "--out"),
    (["profile", "--out", "p.txt"], "--out"),
    (["profile", "--out", "."], "--out"),
    (["profile", "--plot", "missing/p.png"], "--plot"),
    (["profile", "--plot", "p"], "--plot"),
    (["profile", "--plot", "/proc/p.png"], "--plot"),
    (["profile", "--out", "/dev/null"], "--out"),
    (["profile", "--out", "p.csv", "--plot", "q/p.png"], "--plot"),
    (["mesh", "--out", "m.xyz"], "--out"),
    (["mesh", "--out", "none/m.msh"], "--out"),
    (["mesh", "--plot", "."], "--plot"),
    (["mesh", "--out", "/proc/m.msh"], "--out"),
    (["evaluate", "--save", "/proc/run"], "--save"),
    (["evaluate", "--save", "c.yaml"], "--save"),
    (["evaluate", "--save", "c.yaml/run"], "--save"),
    (["run", "--set", "output.directory=/proc/x"], "output.directory"),    # the embedded quickstart
    (["run", "--out", "c.yaml"], "--out"),                                  # an existing file
    (["run", "--out", "c.yaml/run"], "--out"),
]


@pytest.mark.parametrize("argv,option", OUTPUTS, ids=lambda v: " ".join(v) if isinstance(v, list) else v)
def test_output_locations(argv, option):
    assert case(argv, {"c.yaml": "blade: {}\n"}, named=(option,)).code == 2


#: Options: (argv, what the message names; an empty tuple for argparse's own messages).
OPTIONS = [
    (["profile", "--tolerance", "inf"], ("--tolerance",)),
    (["profile", "--tolerance", "nan"], ("--tolerance",)),
    (["profile", "--tolerance=-1"], ("--tolerance",)),
    (["profile", "--tolerance", "1e-15"], ("--tolerance",)),
    (["profile", "--tolerance", "1"], ("--tolerance",)),
    (["profile", "--tolerance", "abc"], ("--tolerance",)),
    (["profile", "--tolerance"], ("--tolerance",)),
    (["profile", "--colour", "red"], ("--colour",)),
    (["profile", "a.yaml", "b.yaml"], ("b.yaml",)),
    (["profile", "missing.yaml"], ("missing.yaml",)),
    (["profile", "--set"], ("--set",)),
    (["profile", "--set", "=5"], ("--set",)),
    (["profile", "--set", "alpha"], ("--set",)),
    (["profile", "--set", ".=1"], ("--set",)),
    (["profile", "--set", "alpha=1", "--set", "alpha=2"], ("alpha",)),
    (["mesh", "--level", "ultra"], ("--level",)),
    (["evaluate", "--every=-1"], ("--every",)),
    (["evaluate", "--every", "1.5"], ("--every",)),
    (["evaluate", "--set", "solver.model=rans"], ("solver.model",)),
    (["validate", "nope"], ("nope",)),
    (["validate", "cavity", "--alpha", "5"], ("--alpha",)),
    (["validate", "cavity", "--level", "huge"], ("--level",)),
    (["status", "no-such-run"], ("no-such-run",)),
    (["resume", "no-such-run"], ("no-such-run",)),
    (["resume", "no-such-run", "--set", "alpha=1"], ("alpha",)),
    (["check", "--set", "algorithm.population=true"], ("algorithm.population",)),
    (["check", "--set", "algorithm.population=1e400"], ("algorithm.population",)),
    (["check", "--set", "objectives=[1"], ("--set objectives",)),
    (["nonsense"], ("nonsense",)),
]


@pytest.mark.parametrize("argv,named", OPTIONS, ids=lambda v: " ".join(v) if isinstance(v, list) else None)
def test_options(argv, named):
    assert case(argv, named=named).code == 2


#: Values out of their range or beyond the mesh's cost (docs/reference/configuration.md, docs/reference/errors.md):
#: (override, what the one message holds: the key and the range it is refused by).
LIMITS = [
    ("mesh.upstream=1e6", "mesh.upstream = 1e+06 chords is outside (0, 100] chords"),
    ("mesh.downstream=1e300", "mesh.downstream = 1e+300 chords is outside"),
    ("mesh.half_height=-1", "mesh.half_height = -1 chords is outside (0, 50]"),
    ("mesh.wall_nodes=" + str(10**12), "mesh.wall_nodes = 1e+12 is outside [16, 4000]"),
    ("mesh.wall_nodes=3", "mesh.wall_nodes = 3 is outside [16, 4000]"),
    ("mesh.growth=1.0000001", "mesh.growth = 1 is outside [1.01, 1.2]"),
    ("mesh.growth=1e9", "mesh.growth = 1e+09 is outside [1.01, 1.2]"),
    ("mesh.y_plus=1e-9", "mesh.y_plus = 1e-09 is outside [0.01, 300]"),
    ("mesh.far_size=1e-6", "mesh.far_size = 1e-06 chords is outside [0.01, 10]"),
    ("mesh.size_gradient=1e-5", "mesh.size_gradient = 1e-05 is outside [0.01, 1]"),
    ("mesh.max_turn=0.001", "mesh.max_turn = 0.001 deg is outside [2, 45]"),
    ("mesh.side_offset=50", "mesh.side_offset = 50 chords is outside (0, 1]"),
    ("mesh.far_size=0.01", "this mesh would have about"),                     # each key in range, the sum not
    ("mesh.flow_speed=1e-300", "the chord Reynolds number"),
    ("mesh.viscosity=1e-300", "the chord Reynolds number"),
    ("mesh.y_plus=300", None),                                                # in range, and the first cell fits
    ("flow.speed=1e-300", "'flow.speed' = 1e-300 m/s is outside [0.001, 100] m/s"),
    ("flow.speed=1e6", "'flow.speed' = 1e+06 m/s is outside"),
    ("flow.density=1e-12", "'flow.density' = 1e-12 kg/m³ is outside [0.1, 20000]"),
    ("flow.viscosity=1e30", "'flow.viscosity' = 1e+30 Pa s is outside [1e-06, 1000]"),
    ("flow.viscosity=1e-6", None),                                            # Re = 1e9: warned by evaluate only
    ("flow.viscosity_ratio=1e9", "'flow.viscosity_ratio' = 1e+09 is outside (0, 10000]"),
    ("flow.span=1e20", "'flow.span' = 1e+20 m is outside (0, 1000] m"),
    ("flow.speed=0.001", "mesh.y_plus = 1 puts the first cell"),            # Re = 100: y+ 1 is 5.7 mm up
    ("solver.max_iter=" + str(10**90), "'solver.max_iter' = 1.000e+90 is outside [1, 100000]"),
    ("solver.max_iter=1000000", "'solver.max_iter' = 1000000 is outside [1, 100000]"),
    ("solver.tol=1e-300", "'solver.tol' = 1e-300 is outside [1e-12, 1]"),
    ("solver.classify_window=" + str(10**9), "'solver.classify_window' = 1000000000 is outside [8, 10000]"),
    ("solver.stop_window=1", "'solver.stop_window' = 1 is outside [2, 10000]"),
    ("solver.limiter_k=1e300", "'solver.limiter_k' = 1e+300 is outside (0, 1000]"),
    ("solver.divergence_factor=1", "'solver.divergence_factor' = 1 is outside (1, 1e+12]"),
    ("solver.velocity_limit=1e300", "'solver.velocity_limit' = 1e+300 m/s is outside (0, 1e+08] m/s"),
]


@pytest.mark.parametrize("override,message", LIMITS, ids=[o for o, _ in LIMITS])
@pytest.mark.parametrize("command", [["profile"], ["mesh", "--out", "m.xyz"]],
                         ids=lambda c: c[0])
def test_values_beyond_their_limits(override, message, command):
    """Refused (exit 2) with the key and its range, before any stage; an accepted value runs ``profile``
    (and ``mesh`` is then refused for its ``--out`` suffix, before meshing)."""
    outcome = case([*command, "--set", override], named=(message,) if message else ("--out",))
    assert outcome.code == (0 if message is None and command == ["profile"] else 2), outcome.err
    if message is None and command == ["profile"]:
        assert outcome.err == ""                                   # no warning where nothing is solved


def test_a_campaign_names_the_range_too():
    case(["check", QUICKSTART, "--set", "flow.speed=1e-300"], named=("'flow.speed' = 1e-300 m/s is outside",))
    case(["check", QUICKSTART, "--set", "mesh.upstream=1e6"], named=("mesh.upstream = 1e+06 chords is outside",))


def test_a_good_run_leaves_exactly_its_files():
    with tempfile.TemporaryDirectory() as tmp:
        outcome = run_cli(["profile", "--out", "p.csv"], Path(tmp))
        check(outcome, Path(tmp))
        assert outcome.code == 0 and [p.name for p in Path(tmp).iterdir()] == ["p.csv"]


# ----------------------------------------------------------------------------------------- hypothesis
#: Override keys: blade parameters, every section's keys, campaign keys, and keys that do not exist.
KEYS = ["alpha", "beta1", "beta1bar", "L", "d_s1", "d_s2", "d_s3", "d_s4", "d_p3", "d_p4", "u_s2", "k2", "R",
        "blade.mode", "blade.continuity", "blade.parameters", "blade.bounds.alpha", "blade.fixed.L", "blade",
        "mesh.level", "mesh.upstream", "mesh.wall_nodes", "mesh.growth", "mesh.y_plus", "mesh",
        "mesh.far_size", "mesh.size_gradient", "mesh.max_turn", "mesh.half_height", "mesh.flow_speed",
        "flow.speed", "flow.density", "flow.span", "flow.intensity", "flow.viscosity", "flow.viscosity_ratio",
        "solver.model", "solver.max_iter", "solver.classify_window", "solver.stop_tol", "solver.velocity_limit",
        "solver.tol", "solver.alpha_u", "solver.limiter", "solver", "colour", "blade.colour", "flow.speed.x",
        "a.b.c.d.e", "blade.parameters.alpha.x"]
CAMPAIGN_KEYS = ["algorithm.population", "algorithm.generations", "algorithm.seed", "objectives",
                 "constraints", "execution.backend", "execution.workers", "output.directory", "convergence"]
SCALARS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(min_value=-100, max_value=100).map(lambda v: f"{v:.6g}"),
    st.integers(min_value=-10**120, max_value=10**120).map(str),
    st.sampled_from(["true", "no", "on", "null", "~", "", ".inf", "-.nan", "0x1F", "0o17", "1_000", "1e400",
                     "2001-01-01", "G1", "toolpath", "design", "coarse", "laminar", "'25'", '"x"', "[1, 2]",
                     "{a: 1}", "[0.004, 0.006]", "&a [*a]", "!!binary aGk=", "!!python/none ''", "*a", "&a 1",
                     "[1", "{", "'", "|", ">", "- x", "? x", "a: b: c", "%TAG", "@x", "`x`", "\t1", "1\x00",
                     "\u202e", "\ufeff1", "9" * 500, "[" * 60 + "]" * 60]),
    st.text(max_size=40),
)


@FAST
@given(key=st.sampled_from(KEYS), value=SCALARS, command=st.sampled_from(["profile", "space"]))
def test_overrides(key, value, command):
    outcome = case([command, "--set", f"{key}={value}"], named=tuple(key.split(".")) + ("--set",))
    assert outcome.code in DOCUMENTED


@FAST
@given(key=st.sampled_from(CAMPAIGN_KEYS + KEYS[:6]), value=SCALARS)
def test_campaign_overrides(key, value):
    case(["check", QUICKSTART, "--set", f"{key}={value}"], named=tuple(key.split(".")) + ("--set",))


SECTION_KEYS = ["blade", "mesh", "flow", "solver", "parameters", "mode", "continuity", "bounds", "fixed",
                "alpha", "L", "level", "speed", "model", "max_iter", "objectives", "algorithm"]
VALUES = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(min_value=-10**30, max_value=10**30),
              st.floats(allow_nan=True), st.text(max_size=20), st.sampled_from(["design", "G1", "coarse"])),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(
        st.sampled_from(SECTION_KEYS) | st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)


def _mutate(text: str, how: str, at: int) -> str | bytes:
    """A YAML text made hostile in one way (``at`` picks where)."""
    lines = text.splitlines(keepends=True) or ["\n"]
    k = at % len(lines)
    return {
        "none": text,
        "duplicate-line": "".join(lines[:k + 1] + [lines[k]] + lines[k + 1:]),
        "truncate": text[: at % (len(text) + 1)],
        "latin1": text.encode() + "é".encode("latin-1"),
        "nul": text + "\x00",
        "tag": text + "\nx: !!python/object:os.system {}\n",
        "anchor-bomb": _bomb(12) + text,
        "tabs": text.replace("  ", "\t"),
    }[how]


@FAST
@given(doc=st.dictionaries(st.sampled_from(SECTION_KEYS), VALUES, max_size=4),
       how=st.sampled_from(["none", "duplicate-line", "truncate", "latin1", "nul", "tag", "anchor-bomb", "tabs"]),
       at=st.integers(min_value=0, max_value=10**6), command=st.sampled_from(["profile", "space", "check"]))
def test_files(doc, how, at, command):
    text = _mutate(yaml.safe_dump(doc, allow_unicode=True), how, at)
    case([command, "c.yaml"], {"c.yaml": text}, named=("c.yaml", "--set"))


@pytest.mark.slow
@SLOW
@given(key=st.sampled_from(KEYS), value=SCALARS, command=st.sampled_from(["profile", "space", "mesh"]))
def test_overrides_long(key, value, command):
    argv = [command, "--set", f"{key}={value}"] + (["--out", "m.xyz"] if command == "mesh" else [])
    case(argv, named=tuple(key.split(".")) + ("--set", "--out"))


@pytest.mark.slow
@SLOW
@given(doc=st.dictionaries(st.sampled_from(SECTION_KEYS), VALUES, max_size=5),
       how=st.sampled_from(["none", "duplicate-line", "truncate", "latin1", "nul", "tag", "anchor-bomb", "tabs"]),
       at=st.integers(min_value=0, max_value=10**6), command=st.sampled_from(["profile", "space", "check"]))
def test_files_long(doc, how, at, command):
    text = _mutate(yaml.safe_dump(doc, allow_unicode=True), how, at)
    case([command, "c.yaml"], {"c.yaml": text}, named=("c.yaml", "--set"))


# ------------------------------------------------------------------------------------ campaign commands
#: A small finished campaign whose store the campaign cases damage (ZDT1, inline: no CFD, well under a second).
ZDT1 = ("analytic: {problem: zdt1, variables: 4}\nalgorithm: {population: 6, generations: 2, seed: 3}\n"
        "execution: {backend: inline}\noutput: {sync: normal}\n")
#: Commands that read a run directory, and the exit statuses each may end with on a damaged store: 0 where the
#: damage missed everything they read, 2 otherwise (``resume``: also 0 after continuing the campaign).
CAMPAIGN_COMMANDS = {"status": ["status", "run"], "status --json": ["status", "run", "--json"],
                     "report": ["report", "run", "--out", "report"],
                     "export": ["export", "run", "--id", "1", "--format", "linuxcnc", "--out", "p.nc"],
                     "resume": ["resume", "run", "--quiet"], "run": ["run", "c.yaml", "--out", "run", "--quiet"]}
#: SQL that damages one value or a table of a store.
SQL_DAMAGES = ["UPDATE evaluations SET {column} = {value} WHERE rowid = (SELECT min(rowid) FROM evaluations)",
               "UPDATE generations SET {column} = {value}", "UPDATE campaign SET config = {value}",
               "DROP TABLE {table}", "DELETE FROM {table}"]


@pytest.fixture(scope="module")
def finished_run(finished_zdt1) -> Path:
    return finished_zdt1


def _damage_bytes(path: Path, how: str, at: float, data: bytes) -> None:
    """Damage the file's bytes: truncate at a share of its length, overwrite from there, or zero a page."""
    size = path.stat().st_size
    offset = int(at * size)
    with open(path, "r+b") as fh:
        if how == "truncate":
            fh.truncate(offset)
        elif how == "overwrite":
            fh.seek(offset)
            fh.write(data)
        else:                                       # a zeroed 4 KiB page, SQLite's page size
            fh.seek(offset // 4096 * 4096)
            fh.write(bytes(4096))


def _damage_sql(path: Path, statement: str) -> None:
    import sqlite3

    db = sqlite3.connect(path)
    try:
        with db:
            db.execute(statement)
    except sqlite3.Error:                           # a column this table does not have: no damage done
        pass
    finally:
        db.close()


def campaign_case(finished_run: Path, command: str, damage) -> Outcome:
    """``millfoil COMMAND`` on a copy of the finished run damaged by ``damage(store)``, checked: a documented
    exit status, no traceback, one error line; the reading commands leave the store byte for byte as it was
    and write nothing when they fail."""
    import shutil

    with tempfile.TemporaryDirectory() as tmp:
        cwd = Path(tmp)
        shutil.copytree(finished_run, cwd / "run", ignore=shutil.ignore_patterns("driver.lock", "*-wal", "*-shm"))
        (cwd / "c.yaml").write_text(ZDT1)
        store = cwd / "run" / "campaign.sqlite"
        damage(store)
        before = store.read_bytes()
        outcome = run_cli(CAMPAIGN_COMMANDS[command], cwd)
        context = f"{command}: exit {outcome.code}\nstderr: {outcome.err[-2000:]}"
        assert outcome.code in {0, 2}, context
        assert "Traceback" not in outcome.err + outcome.out, context
        if outcome.code == 2:
            errors = [line for line in outcome.err.splitlines() if line.startswith("millfoil: error:")]
            assert len(errors) == 1 and len(errors[0]) < 1500, context
            assert not (cwd / "report").exists() and not (cwd / "p.nc").exists(), context
        if command.startswith(("status", "report", "export")) or outcome.code == 2:
            assert store.read_bytes() == before, context
        return outcome


@FAST
@given(command=st.sampled_from(list(CAMPAIGN_COMMANDS)), how=st.sampled_from(["truncate", "overwrite", "zero"]),
       at=st.floats(min_value=0.0, max_value=0.999), data=st.binary(min_size=1, max_size=64))
def test_damaged_store_bytes(finished_run, command, how, at, data):
    campaign_case(finished_run, command, lambda store: _damage_bytes(store, how, at, data))


@FAST
@given(command=st.sampled_from(list(CAMPAIGN_COMMANDS)), statement=st.sampled_from(SQL_DAMAGES),
       table=st.sampled_from(["campaign", "evaluations", "generations"]),
       column=st.sampled_from(["x", "parameters", "objectives", "constraints", "figures", "monitors", "members",
                               "rank", "rng_state", "search", "status", "generation", "key", "reference"]),
       value=st.sampled_from(["'{'", "'[1,'", "'null'", "NULL", "'x'", "-1", "1e999", "X'00ff'", "'\u0000'",
                              "'!!python/object:os.system x'", "'a: [b'", "'{}'", "'[]'", "''"]))
def test_damaged_store_values(finished_run, command, statement, table, column, value):
    campaign_case(finished_run, command,
                  lambda store: _damage_sql(store, statement.format(table=table, column=column, value=value)))


@pytest.mark.slow
@settings(SLOW, max_examples=150)
@given(command=st.sampled_from(list(CAMPAIGN_COMMANDS)), how=st.sampled_from(["truncate", "overwrite", "zero"]),
       at=st.floats(min_value=0.0, max_value=0.999), data=st.binary(min_size=1, max_size=4096))
def test_damaged_store_bytes_long(finished_run, command, how, at, data):
    campaign_case(finished_run, command, lambda store: _damage_bytes(store, how, at, data))


# ------------------------------------------------------------------------------------------ subprocess
SUBPROCESS = [
    (["profile", "c.yaml"], {"c.yaml": _bomb(9)}, "expands to more than"),
    (["profile", "c.yaml"], {"c.yaml": bytes(range(256))}, "not a UTF-8 text file"),
    (["profile", "--set", "alpha=[1"], {}, "--set alpha"),
    (["profile", "--set", "L=1e300"], {}, "'L'"),
    (["profile", "--tolerance", "inf"], {}, "--tolerance"),
    (["evaluate", "--save", "/proc/x"], {}, "--save"),
]


def run_process(argv: list[str], cwd: Path) -> tuple[Outcome, float]:
    """``python -m optimizer.cli ARGV`` in a fresh process in ``cwd``: its outcome and its own peak resident
    memory, MB (from ``os.wait4``, that child's alone: ``RUSAGE_CHILDREN`` is the largest of every child
    this test process ever waited for)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen([sys.executable, "-m", "optimizer.cli", *argv], cwd=cwd, stdout=out, stderr=err,
                                text=True)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        return Outcome(proc.returncode, out.read(), err.read()), usage.ru_maxrss / 1024


@pytest.mark.slow
@pytest.mark.parametrize("argv,files,message", SUBPROCESS, ids=lambda v: " ".join(v) if isinstance(v, list) else None)
def test_real_processes(argv, files, message, tmp_path):
    for name, text in files.items():
        (tmp_path / name).write_bytes(text if isinstance(text, bytes) else text.encode())
    outcome, megabytes = run_process(argv, tmp_path)
    assert outcome.code == 2 and "Traceback" not in outcome.err and message in outcome.err, outcome.err
    assert outcome.err.count("\n") == 1
    assert megabytes < 2048
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(files)


# ------------------------------------------------------------------------------------------------ memory
#: A child that imports the CLI, resets its peak resident memory (Linux: ``5`` to /proc/self/clear_refs, so that
#: the imports' own transient peak does not hide the command's), runs ``millfoil ARGV`` (argv as JSON in argv[1])
#: and prints its resident memory before the command and its peak during it, MB.
_CHILD = """
import contextlib, io, json, sys
from optimizer.cli import main

def status(field):
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) / 1024 for line in fh if line.startswith(field + ":"))

with open("/proc/self/clear_refs", "w") as fh:
    fh.write("5")
before = status("VmRSS")
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    try:
        code = main(json.loads(sys.argv[1]))
    except SystemExit as exc:
        code = exc.code
print(json.dumps({"code": code, "before": before, "after": status("VmHWM")}))
"""
#: The inputs that would cost most if they were not refused or bounded: an alias bomb at the expansion limit, a
#: file of 100 000 characters, an accepted 10 m tool-path blade (the largest the domains allow).
HEAVY = {
    "bomb": (["profile", "c.yaml"], {"c.yaml": _bomb(9)}),
    "long-string": (["check", "c.yaml"], {"c.yaml": FILES["long-string"][0]}),
    "large-blade": (["profile", "--set", "L=10"], {}),
}


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/clear_refs").exists(), reason="needs Linux's /proc/self/clear_refs")
@pytest.mark.parametrize("name", list(HEAVY))
def test_the_heaviest_inputs_stay_within_the_memory_bound(name, tmp_path):
    import json

    argv, files = HEAVY[name]
    for file, text in files.items():
        (tmp_path / file).write_text(text)
    proc = subprocess.run([sys.executable, "-c", _CHILD, json.dumps(argv)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    figures = json.loads(proc.stdout.strip().splitlines()[-1])
    assert figures["code"] in DOCUMENTED, figures
    assert figures["after"] - figures["before"] < MEGABYTES, figures
