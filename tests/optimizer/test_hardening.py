"""Hostile input, class by class: each gets one clear message, a bounded cost and no lost work.

Exit statuses are the documented ones (docs/reference/errors.md): 2 bad input, 3 infeasible, 4 a stage failed. The
fuzzer over all classes together is ``test_hardening_fuzz.py``.
"""

import json
import os
import sys
import types
from pathlib import Path

import pytest
import yaml

from optimizer.cli import EXIT_FAILED, EXIT_INPUT, EXIT_OK, main
from optimizer.config import ConfigError, load_config, shorten
from optimizer.saving import Outputs, WriteFailure, write_all
from optimizer.yamlsource import MAX_DEPTH, MAX_FILE_BYTES, MAX_NUMBER_CHARS, MAX_VALUES, parse_yaml

EXAMPLES = Path(__file__).parents[2] / "configs" / "examples"


def error_of(argv, capsys) -> str:
    """The one error line of a command refused as bad input."""
    assert main(argv) == EXIT_INPUT
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1 and err.startswith("millfoil: error: "), err
    return err


def never(*args, **kwargs):
    """A stage that must not run: the input is refused before it."""
    raise AssertionError("a stage ran before the input was refused")


def write(tmp_path: Path, text: str | bytes, name: str = "c.yaml") -> str:
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return str(path)


# ------------------------------------------------------------------------------------ 1: alias bombs, reprs
def bomb(levels: int, width: int = 9) -> str:
    lines = [f"a0: &a0 [{', '.join(['x'] * width)}]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * width)}]" for i in range(1, levels)]
    return "\n".join(lines) + f"\nblade:\n  parameters:\n    alpha: *a{levels - 1}\n"


@pytest.mark.parametrize("levels", [3, 5, 9, 30])
def test_an_alias_bomb_is_refused_before_it_is_built(levels, tmp_path, capsys):
    """30 levels expand to 9**30 values: built, the test could not end; refused, it ends at once."""
    err = error_of(["profile", write(tmp_path, bomb(levels))], capsys)
    if 9**levels > MAX_VALUES:
        assert f"expands to more than {MAX_VALUES} values" in err and len(err) < 300
    else:       # within the limit: an ordinary error, its input shortened
        assert "'blade.parameters.alpha': Input should be a valid number" in err and len(err) < 1000


@pytest.mark.parametrize("text,message", ids=["alias-seq", "alias-map", "deep-flow", "deep-block", "digits"],
                         argvalues=[
    ("a: &a [*a]", "recursive alias"),
    ("a: &a {b: *a}", "recursive alias"),
    ("[" * 200 + "]" * 200, f"nested more than {MAX_DEPTH} levels"),
    ("x:\n" + "".join(" " * i + f"k{i}:\n" for i in range(1, 60)), f"nested more than {MAX_DEPTH} levels"),
    ("a: " + "7" * 5000, f"limited to {MAX_NUMBER_CHARS} characters"),
])
def test_yaml_structure_limits(text, message):
    with pytest.raises(ValueError, match=message):
        parse_yaml(text, "f.yaml")


def test_a_legitimate_anchor_is_still_read():
    data, _ = parse_yaml("b: &r [0.004, 0.006]\nc: *r\n<<: {d: 1}\n", "f.yaml")
    assert data == {"b": [0.004, 0.006], "c": [0.004, 0.006], "d": 1}


def test_messages_show_a_shortened_input(tmp_path, capsys):
    items = ", ".join(str(i) for i in range(5000))
    err = error_of(["profile", write(tmp_path, f"blade:\n  parameters:\n    alpha: [{items}]\n")], capsys)
    assert "'blade.parameters.alpha'" in err and "..." in err and len(err) < 300
    assert len(shorten(list(range(10**5)))) < 100 and len(shorten("x" * 10**6)) < 100
    assert len(shorten({"a": [[[[1]]]] * 100})) < 100


# --------------------------------------------------------------------------------------- 2: output paths
@pytest.mark.parametrize("argv,message", [
    (["profile", "--out", "missing/dir/p.csv"], "--out missing/dir/p.csv: directory missing/dir does not exist"),
    (["profile", "--out", "."], "--out . is a directory"),
    (["profile", "--out", "p.txt"], "--out p.txt: unknown file type .txt; allowed: .csv"),
    (["profile", "--plot", "missing/p.png"], "--plot missing/p.png: directory missing does not exist"),
    (["profile", "--plot", "p.csv"], "unknown file type .csv"),
    (["profile", "--out", "/proc/p.csv"], "--out /proc/p.csv: cannot create a file in /proc"),
    (["profile", "--out", "/dev/null.csv/x.csv"], "does not exist"),
    (["mesh", "--out", "m.xyz"], "--out m.xyz: unknown file type .xyz; allowed: .msh, .vtu"),
    (["mesh", "--plot", "sub"], "--plot sub is a directory"),
    (["evaluate", "--save", "/proc/x"], "--save /proc/x: cannot create a file in /proc"),
    (["evaluate", "--save", "afile"], "--save afile exists and is not a directory"),
    (["evaluate", "--save", "sub/result.json/x"], "is not a directory"),
])
def test_output_locations_are_refused_before_any_stage(argv, message, tmp_path, capsys, monkeypatch):
    import optimizer.cli.blade
    import optimizer.cli.evaluate
    import optimizer.cli.mesh

    for module, stage in ((optimizer.cli.blade, "build_blade"), (optimizer.cli.mesh, "blade_profile"),
                          (optimizer.cli.mesh, "blade_mesh"), (optimizer.cli.evaluate, "evaluate")):
        monkeypatch.setattr(module, stage, never)                   # no profile, no mesh, no solve
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    (tmp_path / "afile").write_text("x")
    (tmp_path / "sub" / "result.json").write_text("{}")
    assert message in error_of(argv, capsys)
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["afile", "result.json", "sub"]


def test_a_plot_failing_after_the_csv_leaves_neither(tmp_path, capsys, monkeypatch):
    def plot_profile(profile, path):
        Path(path).write_text("half a figure")
        raise RuntimeError("no")

    monkeypatch.setitem(sys.modules, "geometry.plot", types.SimpleNamespace(plot_profile=plot_profile))
    assert main(["profile", "--out", str(tmp_path / "p.csv"), "--plot", str(tmp_path / "p.png")]) == EXIT_FAILED
    err = capsys.readouterr().err
    assert err.startswith("millfoil: error: cannot write") and "no file was written" in err
    assert list(tmp_path.iterdir()) == []


def test_outputs_are_renamed_together_with_the_usual_mode(tmp_path):
    written = write_all([(tmp_path / "a.csv", lambda p: p.write_text("a")),
                         (tmp_path / "new" / "b.csv", lambda p: p.write_text("b"))])
    assert [p.read_text() for p in written] == ["a", "b"]
    umask = os.umask(0)
    os.umask(umask)
    assert (tmp_path / "a.csv").stat().st_mode & 0o777 == 0o666 & ~umask


_FORKED_WRITERS = """
import os, sys, threading
from pathlib import Path
from optimizer.saving import WriteFailure, write_all

tmp_path, mode = Path(sys.argv[1]), sys.argv[2]
if mode == "thread":            # another thread running: the writers must stay in this process
    threading.Thread(target=threading.Event().wait, daemon=True).start()


def writer(text):
    def write(p):
        if mode == "die" and text == 2:
            os._exit(9)             # a worker killed mid-figure
        p.write_text(f"{text} {os.getpid()}")
    return write


files = [(tmp_path / f"{k}.csv", writer(k)) for k in range(6)]
try:
    write_all(files, jobs=3)
except WriteFailure as exc:
    print("failed:", exc)
print("parent", os.getpid())
if mode == "fork":
    (tmp_path / "0.csv").write_text("old")
    try:
        write_all([*files[:4], (tmp_path / "d" / "4.csv", lambda p: (_ for _ in ()).throw(OSError("disk full"))),
                   files[5]], jobs=3)
    except WriteFailure as exc:
        print("failed:", exc)
"""


def _forked_writers(tmp_path, mode: str) -> str:
    """The output of :data:`_FORKED_WRITERS` run in a fresh interpreter (no thread of this test session's)."""
    import subprocess

    proc = subprocess.run([sys.executable, "-c", _FORKED_WRITERS, str(tmp_path), mode], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


def test_writers_in_forked_processes_write_the_same_files_renamed_in_order(tmp_path):
    """``jobs=3`` in a process with one thread: the writers run in other processes (each file records its
    writer's pid), the files are those of one process, renamed in the order given; one failing writer leaves
    none, its file named."""
    out = _forked_writers(tmp_path, "fork")
    parent = out.split("parent ")[1].split()[0]
    texts = [(tmp_path / f"{k}.csv").read_text().split() for k in range(6)]
    assert [t[0] for t in texts[1:]] == [str(k) for k in range(1, 6)]
    assert parent not in {t[1] for t in texts[1:]}
    umask = os.umask(0)
    os.umask(umask)
    assert (tmp_path / "1.csv").stat().st_mode & 0o777 == 0o666 & ~umask
    assert "failed: cannot write " in out and "4.csv: OSError: disk full; no file was written" in out
    assert (tmp_path / "0.csv").read_text() == "old" and not (tmp_path / "d").exists()
    assert not list(tmp_path.glob(".*partial*"))


def test_writers_stay_in_the_process_while_another_thread_runs(tmp_path):
    """A fork would copy the other thread's locks, held: the writers run in the calling process instead."""
    out = _forked_writers(tmp_path, "thread")
    parent = out.split("parent ")[1].split()[0]
    assert {(tmp_path / f"{k}.csv").read_text().split()[1] for k in range(6)} == {parent}


def test_a_writer_process_that_dies_fails_the_write_instead_of_hanging(tmp_path):
    out = _forked_writers(tmp_path, "die")
    assert "failed: cannot write " in out and "no file was written" in out, out
    assert not list(tmp_path.glob("*.csv")) and not list(tmp_path.glob(".*partial*"))


def test_a_failed_write_removes_the_staged_files_and_the_directories_it_made(tmp_path):
    (tmp_path / "keep.csv").write_text("old")
    with pytest.raises(WriteFailure, match="cannot write .*c.csv: OSError: disk full"):
        write_all([(tmp_path / "keep.csv", lambda p: p.write_text("new")),
                   (tmp_path / "d" / "e" / "c.csv", lambda p: (_ for _ in ()).throw(OSError("disk full")))])
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["keep.csv"]
    assert (tmp_path / "keep.csv").read_text() == "old"         # the old file is intact
    with pytest.raises(RuntimeError), Outputs() as outputs:
        outputs.stage(tmp_path / "x.csv", lambda p: p.write_text("x"))
        raise RuntimeError
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["keep.csv"]


# ------------------------------------------------------------------------------------ 3: non-UTF-8, binary
@pytest.mark.parametrize("data,message", [
    (b"\xff\xfe\x00b\x80lade", "not a UTF-8 text file (byte 0xff at offset 0)"),
    (b"blade:\n  mode: d\xe9sign\n", ":2: not a UTF-8 text file (byte 0xe9"),
    (b"blade: {}\x00\x01", "unacceptable character #x0000"),
    (bytes(range(256)), "not a UTF-8 text file"),
    (b"\x89PNG\r\n\x1a\n" + b"\x00" * 64, "not a UTF-8 text file"),
])
def test_a_binary_or_non_utf8_file_is_a_clear_error(data, message, tmp_path, capsys):
    assert message in error_of(["profile", write(tmp_path, data)], capsys)


def test_a_huge_file_and_a_device_are_read_only_up_to_the_limit(tmp_path, capsys):
    path = write(tmp_path, "#" * (MAX_FILE_BYTES + 10))
    assert "larger than 1024 KiB" in error_of(["profile", path], capsys)
    assert "larger than 1024 KiB" in error_of(["profile", "/dev/zero"], capsys)
    assert "Is a directory" in error_of(["profile", str(tmp_path)], capsys)


def test_a_utf8_file_with_a_byte_order_mark_is_read(tmp_path):
    config = load_config(write(tmp_path, b"\xef\xbb\xbfblade:\n  parameters: {alpha: 12}\n"))
    assert config.blade.parameters["alpha"] == 12


# ------------------------------------------------------------------------------------- 4: --set YAML errors
@pytest.mark.parametrize("override,message", [
    ("alpha=[1", "--set alpha (column 3): not valid YAML: expected ',' or ']'"),
    ("alpha={", "--set alpha (column 2): not valid YAML"),
    ("blade.mode=!!python/name:os.system", "--set blade.mode (column 1): not valid YAML: could not determine"),
    ("alpha=&a [*a]", "--set alpha (column 1): an alias refers to a value that contains it"),
    ("alpha='unterminated", "--set alpha (column"),
    ("alpha=\t1", "--set alpha (column 1): not valid YAML"),
    ("alpha=1\x00", "--set alpha: not valid YAML: unacceptable character #x0000"),
    ("alpha=a: b: c", "--set alpha (column 5): not valid YAML: mapping values are not allowed here"),
])
def test_an_override_that_is_not_yaml_names_the_override(override, message, capsys):
    err = error_of(["profile", "--set", override], capsys)
    assert message in err and "<unicode string>" not in err


# ------------------------------------------------------------------------------------------------ 5: scale
@pytest.mark.parametrize("argv,message", [
    (["--set", "L=1e6"], "parameter 'L' = 1000000.0 m is out of its domain [0.001, 10]"),
    (["--set", "L=1e300"], "out of its domain [0.001, 10]"),
    (["--set", "L=1e-300"], "out of its domain [0.001, 10]"),
    (["--set", "d_s1=1e6"], "parameter 'd_s1' = 1000000.0 m is out of its domain (0, 10]"),
    (["--set", "alpha=1e400"], "'blade.parameters.alpha': Input should be a finite number (got '1e400')"),
    (["--set", "alpha=-.inf"], "'blade.parameters.alpha': Input should be a finite number"),
    (["--set", "alpha=.nan"], "'blade.parameters.alpha': Input should be a finite number"),
    (["--set", "flow.speed=.inf"], "'flow.speed': Input should be a finite number"),
    (["--set", "mesh.upstream=.nan"], "'mesh.upstream': Input should be a finite number"),
    (["--set", "alpha=" + "9" * 5000], "a number of 5000 characters"),
    (["--set", "alpha=" + "9" * 400], "a number of 400 characters"),
    (["--set", "alpha=1" + "0" * 99], "parameter 'alpha' = 1e+99 deg is out of its domain"),
    (["--tolerance", "1e-12"], "--tolerance 1e-12 m is outside [1e-09, 0.001] m"),
    (["--tolerance", "inf"], "--tolerance inf m is outside"),
    (["--tolerance", "nan"], "--tolerance nan m is outside"),
    (["--tolerance", "0"], "--tolerance 0 m is outside"),
    (["--tolerance=-1e-6"], "--tolerance -1e-06 m is outside"),
    (["--set", "L=10", "--tolerance", "1e-8"], "outside [1e-07, 0.1] m"),
])
def test_inputs_that_cannot_be_computed_are_refused_up_front_with_the_reason(argv, message, capsys, monkeypatch):
    import optimizer.cli.blade

    monkeypatch.setattr(optimizer.cli.blade, "build_blade", never)
    assert message in error_of(["profile", *argv], capsys)


@pytest.mark.slow
@pytest.mark.parametrize("argv", [["--set", "L=10"], ["--set", "L=0.001"], ["--tolerance", "1e-9"],
                                  ["--set", "L=10", "--tolerance", "1e-7"]])
def test_the_limits_themselves_are_computed_with_a_bounded_profile(argv, capsys):
    """At the edges of the accepted domains (the longest blade, the finest tolerance, both) a profile has at most
    ~20 000 points (docs/reference/errors.md; measured 20 273 for L = 10 m at 1e-7 m): its cost, and every later
    stage's, grows with them. 30 000 leaves room for a change of the outline's sampling, not for a runaway."""
    assert main(["profile", "--json", *argv]) in (0, 3)
    assert json.loads(capsys.readouterr().out)["points"] < 30_000


# ------------------------------------------------------------------------------ 6: likely mistakes refused
@pytest.mark.parametrize("text,message", [
    ("blade:\n  parameters:\n    alpha: 20\n    alpha: 25\n", "c.yaml:4: duplicate key 'alpha' (first given on line"),
    ("blade: {mode: design}\nblade: {mode: toolpath}\n", "c.yaml:2: duplicate key 'blade' (first given on line 1)"),
    ("flow: {speed: 1, 'speed': 2}\n", "duplicate key 'speed'"),
    ("blade:\n  parameters:\n    alpha: true\n", "c.yaml:3: 'blade.parameters.alpha': a number is expected, not"),
    ("blade:\n  parameters: {alpha: no}\n", "'blade.parameters.alpha': a number is expected, not a boolean"),
    ("flow:\n  speed: on\n", "c.yaml:2: 'flow.speed': a number is expected, not a boolean"),
    ("mesh:\n  wall_nodes: yes\n", "'mesh.wall_nodes': a number is expected, not a boolean"),
    ("solver:\n  max_iter: true\n", "'solver.max_iter': a number is expected, not a boolean"),
    ("blade:\n  bounds: {alpha: [0, true]}\n", "'blade.bounds.alpha.1': a number is expected, not a boolean"),
    ("blade:\n  fixed: {alpha: false}\n", "'blade.fixed.alpha': a number is expected, not a boolean"),
    ("", "c.yaml is empty: a configuration file sets at least one section"),
    ("# only a comment\n", "is empty"),
    ("{}\n", "is empty"),
    ("--- \n...\n", "is empty"),
    ("- blade\n", "must be a YAML mapping of sections (blade, mesh, flow, solver), not list"),
    ("42\n", "not int 42"),
])
def test_likely_mistakes_are_refused(text, message, tmp_path, capsys):
    assert message in error_of(["profile", write(tmp_path, text)], capsys)


def test_the_geometry_names_a_non_finite_value_as_such():
    from geometry import BladeSpec, ParameterError

    with pytest.raises(ParameterError, match=r"'alpha' must be a finite number in \[-90, 90\] deg, got inf"):
        BladeSpec.from_values("design", "C2", {"alpha": float("inf")})


def test_a_boolean_stays_a_boolean_where_one_is_expected():
    assert load_config(overrides=["solver.initial=rest"]).solver.initial == "rest"
    with pytest.raises(ConfigError, match="'solver.model' = True is not allowed"):
        load_config(overrides=["solver.model=true"])


def test_an_override_given_twice_is_refused(capsys):
    err = error_of(["profile", "--set", "alpha=10", "--set", "blade.parameters.alpha=12"], capsys)
    assert "--set blade.parameters.alpha: the key is given twice ('alpha=10' and 'blade.parameters.alpha=12')" in err
    assert "--set blade..mode: a key is dotted names" in error_of(["profile", "--set", "blade..mode=x"], capsys)


def test_no_file_is_the_embedded_default(capsys):
    assert main(["profile", "--json"]) == EXIT_OK
    capsys.readouterr()


# ---------------------------------------------------------------------------------------------- 7: messages
def test_help_descriptions_are_wrapped(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")
    for command in ("profile", "space", "mesh", "evaluate", "validate", "run", "check"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        out = capsys.readouterr().out
        assert max(len(line) for line in out.splitlines()) <= 100, command
        assert "usage: millfoil" in out


def test_validate_prints_the_whole_description_and_no_raw_dict():
    from optimizer.cli.validate import _description, _details
    from solver.validation import CASES

    for case in CASES.values():
        text = _description(case, "")
        assert text.endswith("."), text
    lines = _details({"re100": {"cells": 1813, "rms": 0.20599041287195488}, "meshes": [{"h": 0.1}]}, "  ")
    assert lines == ["  re100:", "    cells 1813, rms 0.206", "  meshes:", "    h 0.1"]


@pytest.mark.slow
def test_mesh_messages_have_no_numpy_reprs(capsys):
    assert main(["mesh", "--level", "coarse", "--set", "mesh.upstream=0.01"]) == EXIT_FAILED
    err = capsys.readouterr().err
    assert "does not contain the O-layer" in err and "np.float64" not in err and "Traceback" not in err


def test_domains_in_the_docs_are_the_accepted_ones():
    from geometry import parameters_of

    table = (Path(__file__).parents[2] / "docs" / "explanation" / "geometry.md").read_text()
    for name in ("alpha", "beta1", "beta1bar", "L"):
        lo, hi = parameters_of("design", "G0")[name].domain
        shown = f"[{lo:g}, {hi:g}]".replace("-", "−")
        assert f"| {name} |" in table and shown in table.split(f"| {name} |")[1].split("\n")[0], name


def test_every_limit_is_in_the_errors_reference():
    from geometry.parameters import MAX_LENGTH, MIN_CHORD
    from optimizer.cli.blade import TOLERANCE_RANGE

    doc = (Path(__file__).parents[2] / "docs" / "reference" / "errors.md").read_text()
    for value in (MAX_VALUES, MAX_DEPTH, MAX_NUMBER_CHARS, MAX_FILE_BYTES // 1024, MAX_LENGTH, MIN_CHORD,
                  *TOLERANCE_RANGE):
        assert f"{value:g}" in doc, value
    assert "](reference/errors.md)" in (Path(__file__).parents[2] / "docs" / "index.md").read_text()


def test_the_shipped_configurations_pass_the_new_checks():
    configs = Path(__file__).parents[2] / "configs"
    for path in configs.rglob("*.yaml"):
        data, _ = parse_yaml(path.read_text(), str(path))     # no duplicates, within every limit
        assert isinstance(data, dict) and yaml.safe_load(path.read_text()) == data


@pytest.mark.slow
def test_output_to_a_reader_that_has_gone_ends_quietly():
    """``millfoil status RUN | head``: the reader closes the pipe before the command writes; 141, nothing
    on stderr (no traceback, no second error from the final flush)."""
    import subprocess

    root = Path(__file__).parents[2]
    run = root / "runs" / "examples" / "paper" / "coarse" / "design_g1"
    proc = subprocess.Popen([sys.executable, "-m", "optimizer.cli", "status", str(run)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env={**os.environ, "PYTHONPATH": str(root)})
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141 and err == "", err
