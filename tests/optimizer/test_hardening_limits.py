"""Limits of the mesh, flow and solver values: what the inputs drive is bounded or scaled, and what cannot be
computed is refused up front, with the reason; the fuzzer's corpus of them is ``test_hardening_fuzz.py::LIMITS``."""

from pathlib import Path

import pytest

from meshing import BOUNDS, CELL_BUDGET, REYNOLDS_RANGE
from optimizer.cli import EXIT_INPUT, main
from optimizer.config import (
    VALIDATED_REYNOLDS,
    ConfigError,
    ConfigWarning,
    FlowConfig,
    SolverConfig,
    load_config,
    range_error,
)

DOCS = Path(__file__).parents[2] / "docs" / "reference"
#: The limits that span several keys (Reynolds number, cell budget, validated ranges).
DOC = (DOCS / "errors.md").read_text()
#: Every key's own range, generated from the schema (optimizer.reference).
KEYS = (DOCS / "configuration.md").read_text()


def _range_text(section: str, key: str, model) -> str:
    err = {"type": "less_than_equal", "input": 0.0}
    return range_error(err, (section, key), type("S", (), {"model_fields": {section: type(
        "F", (), {"annotation": model})}})).split(" is outside ")[1].split(":")[0]


def _row(section: str, key: str) -> str:
    """The line of ``key`` in the table of ``section`` on the generated configuration page."""
    table = KEYS.split(f"\n## {section}\n", 1)[1].split("\n## ", 1)[0]
    return next(line for line in table.splitlines() if line.startswith(f"| `{key}` |"))


def test_every_bound_is_in_the_docs():
    for name, bound in BOUNDS.items():
        if name not in ("flow_speed", "viscosity"):       # bounded through the Reynolds number
            assert bound.text() in _row("mesh", name), name
    for section, model in (("flow", FlowConfig), ("solver", SolverConfig)):
        for key, info in model.model_fields.items():
            if info.metadata:
                row = _row(section, key)
                assert _range_text(section, key, model) in row, (key, row)
    doc = _exponents(DOC)
    assert f"[{_exponents(f'{REYNOLDS_RANGE[0]:g}, {REYNOLDS_RANGE[1]:g}')}]" in doc
    assert f"{CELL_BUDGET:,}".replace(",", " ") in DOC
    for lo, hi in VALIDATED_REYNOLDS.values():
        assert _exponents(f"[{lo:g}, {hi:g}]") in doc, (lo, hi)


def _exponents(text: str) -> str:
    """``1e+09`` and ``1e9`` read alike."""
    return text.replace("e+0", "e").replace("e+", "e")


def test_a_refusal_names_the_key_the_value_the_range_and_why(capsys):
    assert main(["profile", "--set", "mesh.upstream=1e6"]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("millfoil: error: mesh.upstream = 1e+06 chords is outside "
                                                   "(0, 100] chords: a larger domain only adds far-field cells")
    with pytest.raises(ConfigError, match=r"^c\.yaml:2: 'flow\.speed' = 1e-300 m/s is outside \[0\.001, 100\] m/s: "):
        _from_text("flow:\n  speed: 1.0e-300\n")
    with pytest.raises(ConfigError, match=r"^c\.yaml:3: mesh\.growth = 1\.5 is outside"):
        _from_text("mesh:\n  level: fine\n  growth: 1.5\n")


def test_an_override_refused_is_located_at_its_set_item_not_the_file_line(tmp_path, capsys):
    """A value a ``--set`` gave is reported as ``--set KEY=VALUE``: the file line it replaced (or the embedded
    campaign's) holds another value. The file's own values keep ``FILE:LINE``."""
    from optimizer.config import Config
    from optimizer.yamlsource import parse_yaml

    raw, source = parse_yaml("flow:\n  speed: 1.0e-300\nmesh:\n  level: fine\n", "c.yaml")
    with pytest.raises(ConfigError, match=r"^--set flow\.speed=2e3: 'flow\.speed' = 2000 m/s is outside"):
        Config.from_mapping(raw, ["flow.speed=2e3"], source=source)
    with pytest.raises(ConfigError, match=r"^c\.yaml:2: 'flow\.speed' = 1e-300 m/s is outside"):
        Config.from_mapping(raw, ["mesh.level=coarse"], source=source)
    out = tmp_path / "never"
    assert main(["run", "--set", "solver.green_gauss_relaxation=0", "--out", str(out)]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert err.startswith("millfoil: error: --set solver.green_gauss_relaxation=0: 'solver.green_gauss_relaxation' "
                          "= 0 is outside (0, 1]") and not out.exists()


def _from_text(text: str):
    from optimizer.config import Config
    from optimizer.yamlsource import parse_yaml

    raw, source = parse_yaml(text, "c.yaml")
    return Config.from_mapping(raw, source=source)


def test_a_free_chord_is_checked_at_both_ends_of_its_range():
    """Campaign spaces: the mesh must serve the smallest chord (its Reynolds number) and the largest (its
    cells); a design with the default flow and L down to 1 mm has Re = 1e4, where y+ = 1 is 0.1 mm."""
    config = load_config(overrides=["blade.bounds.L=[0.001, 0.1]"], blade_values=False)
    assert config.space_chords() == (0.001, 0.1)
    with pytest.raises(ConfigError, match="puts the first cell"):
        load_config(overrides=["blade.bounds.L=[0.001, 0.1]", "mesh.y_plus=30"], blade_values=False)


def test_a_reynolds_number_outside_the_validated_range_is_warned_not_refused(monkeypatch, capsys):
    import optimizer.cli.evaluate as command

    def stop(*args, **kwargs):
        raise ConfigError("stopped before the solve")

    monkeypatch.setattr(command, "evaluate", stop)
    assert main(["evaluate", "--set", "flow.viscosity=1e-6"]) == EXIT_INPUT
    err = capsys.readouterr().err.splitlines()
    assert err[0] == ("millfoil: warning: the chord Reynolds number speed * L * density / viscosity = 9.98e+08 is "
                      "outside [100000, 1e+07], the range the sst model was validated for: the results are "
                      "unverified")
    assert err[1] == "millfoil: error: stopped before the solve"
    with pytest.warns(ConfigWarning):
        load_config(overrides=["solver.model=laminar"]).warn_reynolds(0.1)      # laminar at Re = 1e6
    assert load_config().reynolds_warning(0.1) is None                          # the paper's blades
    assert load_config(overrides=["solver.model=laminar", "flow.speed=0.2", "flow.viscosity=0.9982", "mesh.y_plus=0.05"]
                       ).reynolds_warning(0.1) is None                          # the laminar test, Re = 20
