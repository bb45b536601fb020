"""Parameter space (Table 3 and 6) and clear errors for bad input."""

import numpy as np
import pytest

from geometry import BladeSpec, ParameterError, ParameterSpace, parameters_of
from geometry.examples import TABLE4_C2_DESIGN

COUNTS = {"G0": 16, "G1": 14, "C1": 13, "G2": 13, "C2": 11}  # Table 3, without the cutter radius


@pytest.mark.parametrize("continuity,count", COUNTS.items())
def test_parameter_counts_of_table3(continuity, count):
    assert len(parameters_of("design", continuity)) == count
    assert len(parameters_of("toolpath", continuity)) == count + 1  # + R


def test_table6_defaults():
    design, toolpath = ParameterSpace.default("design", "G1"), ParameterSpace.default("toolpath", "G1")
    assert design.fixed == {"L": 0.1, "d_s4": 0.002, "d_p4": 0.002}
    assert toolpath.fixed == {"L": 0.1, "d_s4": 0.002, "d_p4": 0.002, "R": 0.005}
    assert len(design.names) == 11
    i = design.names.index("d_s1")
    assert (design.lower[i], design.upper[i]) == (0.005, 0.008)
    assert (toolpath.lower[i], toolpath.upper[i]) == (0.008, 0.011)
    j = design.names.index("alpha")
    assert (design.lower[j], design.upper[j]) == (-5.0, 25.0)


def test_space_overrides():
    space = ParameterSpace.default("toolpath", "C2", bounds={"R": (0.004, 0.006)}, fixed={"alpha": 10.0})
    assert "R" in space.names and "alpha" not in space.names and space.fixed["alpha"] == 10.0
    x = space.sample(3, np.random.default_rng(0))
    assert all(space.spec(row)["alpha"] == 10.0 for row in x)
    with pytest.raises(ParameterError, match="unknown parameter 'k2'"):
        ParameterSpace.default("toolpath", "C2", bounds={"k2": (1, 2)})


@pytest.mark.parametrize("mode,continuity,values,match", [
    ("milling", "C2", {}, "unknown mode 'milling'; allowed: design, toolpath"),
    ("design", "G3", {}, "unknown continuity 'G3'; allowed: G0, G1, C1, G2, C2"),
    ("design", "C2", {"d_p1": 0.005}, "unknown parameter 'd_p1' for a C2 design blade; allowed: L, alpha"),
    ("design", "C2", {"R": 0.005}, "unknown parameter 'R'"),
    ("design", "C2", {"alpha": None}, "parameter 'alpha' must be a number"),
    ("design", "C2", {"u_s2": 1.5}, r"parameter 'u_s2' = 1.5 - is out of its domain \[0, 1\]"),
    ("design", "C2", {"d_s1": 0.0}, r"parameter 'd_s1' = 0.0 m is out of its domain \(0, 10\]"),
    ("design", "C2", {"alpha": 95}, "parameter 'alpha' = 95"),
])
def test_bad_input_names_the_problem(mode, continuity, values, match):
    with pytest.raises(ParameterError, match=match):
        BladeSpec.from_values(mode, continuity, {**TABLE4_C2_DESIGN["parameters"], **values})


def test_missing_parameter_names_it_and_the_required_ones():
    values = dict(TABLE4_C2_DESIGN["parameters"])
    del values["u_s2"]
    with pytest.raises(ParameterError, match=r"missing parameter 'u_s2' for a C2 design blade \(required: alpha"):
        BladeSpec.from_values("design", "C2", values)


def test_fixed_parameters_take_their_default():
    values = {k: v for k, v in TABLE4_C2_DESIGN["parameters"].items() if k not in ("L", "d_s4")}
    spec = BladeSpec.from_values("design", "c2", values)
    assert spec["L"] == 0.1 and spec["d_s4"] == 0.002



def test_draw_feasible_returns_a_feasible_blade_and_counts_its_draws():
    import numpy as np

    from geometry.draws import draw_feasible

    space = ParameterSpace.default("design", "G0")      # about a third of uniform draws are feasible
    spec, result, draws = draw_feasible(space, np.random.default_rng(3), 100)
    assert result is not None and result.feasible and 1 <= draws <= 100
    again, _, same = draw_feasible(space, np.random.default_rng(3), 100)
    assert same == draws and again.values == spec.values                  # seeded: the same blade
    assert draw_feasible(space, np.random.default_rng(3), 0) == (None, None, 0)   # no budget, no blade
