"""Campaign configuration: defaults, the resolved campaign, and malformed files whose error names the key,
the file and the line (at least 30 malformed configs, each with the key and line)."""

from __future__ import annotations

import textwrap

import pytest

from optimizer.campaign.config import CampaignConfig, load_campaign
from optimizer.config import ConfigError
from optimizer.yamlsource import parse_yaml

# (name, YAML text, the key the message must name, the line it must give). Every file is a small but
# otherwise valid campaign; the marked line holds the mistake.
MALFORMED = [
    ("unknown section", "objectivs:\n  - figure: fy\n", "objectivs", 1),
    ("objective unknown key", "objectives:\n  - figure: fy\n    sens: max\n", "objectives.0.sens", 3),
    ("objective sense", "objectives:\n  - figure: fy\n    sense: maximum\n", "objectives.0.sense", 3),
    ("objective figure", "objectives:\n  - figure: c_max\n  - figure: lift\n", "objectives.1.figure", 3),
    ("objective abs", "objectives:\n  - figure: fy\n    abs: maybe\n", "objectives.0.abs", 3),
    ("objective reference", "objectives:\n  - figure: fy\n    reference: high\n", "objectives.0.reference", 3),
    ("objectives not a list", "algorithm:\n  seed: 2\nobjectives: fy\n", "objectives", 3),
    ("objective without figure", "objectives:\n  - sense: max\n", "objectives.0.figure", 2),
    ("constraint without bound", "constraints:\n  - figure: c_max\n", "constraints.0", 2),
    ("constraint bounds crossed", "constraints:\n  - figure: c_max\n    lower: 30\n    upper: 20\n",
     "constraints.0", 2),
    ("constraint figure", "constraints:\n  - figure: drag\n    upper: 3\n", "constraints.0.figure", 2),
    ("constraint unknown key", "constraints:\n  - figure: c_max\n    max: 3\n", "constraints.0.max", 3),
    ("constraint bound type", "constraints:\n  - figure: c_max\n    upper: high\n", "constraints.0.upper", 3),
    ("oscillating policy", "convergence:\n  oscillating: average\n", "convergence.oscillating", 2),
    ("max amplitude", "convergence:\n  max_amplitude: -0.01\n", "convergence.max_amplitude", 2),
    ("convergence unknown key", "convergence:\n  not_converged: accept\n", "convergence.not_converged", 2),
    ("population", "algorithm:\n  population: 1\n", "algorithm.population", 2),
    ("population type", "algorithm:\n  population: many\n", "algorithm.population", 2),
    ("generations", "algorithm:\n  population: 8\n  generations: 0\n", "algorithm.generations", 3),
    ("seed", "algorithm:\n  seed: -1\n", "algorithm.seed", 2),
    ("crossover eta", "algorithm:\n  crossover:\n    eta: 0\n", "algorithm.crossover.eta", 3),
    ("crossover prob", "algorithm:\n  crossover:\n    prob: 1.5\n", "algorithm.crossover.prob", 3),
    ("mutation prob", "algorithm:\n  mutation:\n    prob: -0.1\n", "algorithm.mutation.prob", 3),
    ("mutation unknown key", "algorithm:\n  mutation:\n    rate: 0.1\n", "algorithm.mutation.rate", 3),
    ("algorithm unknown key", "algorithm:\n  pop: 10\n", "algorithm.pop", 2),
    ("backend", "execution:\n  backend: kubernetes\n", "execution.backend", 2),
    ("workers", "execution:\n  workers: 0\n", "execution.workers", 2),
    ("timeout", "execution:\n  timeout: -5\n", "execution.timeout", 2),
    ("execution unknown key", "execution:\n  threads: 4\n", "execution.threads", 2),
    ("cluster unknown key", "execution:\n  backend: slurm\n  cluster:\n    queues: short\n",
     "execution.cluster", 4),
    ("output unknown key", "output:\n  dir: runs/x\n", "output.dir", 2),
    ("analytic problem", "analytic:\n  problem: zdt9\n", "analytic.problem", 2),
    ("analytic variables", "analytic:\n  variables: 1\n", "analytic.variables", 2),
    ("blade mode", "blade:\n  mode: milled\n", "blade.mode", 2),
    ("blade continuity", "blade:\n  continuity: G3\n", "blade.continuity", 2),
    ("bounds unknown parameter", "blade:\n  mode: design\n  continuity: G1\n  bounds:\n    gamma: [0, 1]\n",
     "gamma", 5),
    ("bounds crossed", "blade:\n  mode: design\n  continuity: G1\n  bounds:\n    alpha: [10, 5]\n", "alpha", 5),
    ("bounds not a pair", "blade:\n  bounds:\n    alpha: 5\n", "blade.bounds.alpha", 3),
    ("mesh level", "mesh:\n  level: ultra\n", "mesh.level", 2),
    ("mesh unknown key", "mesh:\n  level: coarse\n  halfheight: 1\n", "mesh.halfheight", 3),
    ("flow speed", "flow:\n  speed: -10\n", "flow.speed", 2),
    ("solver model", "solver:\n  model: kepsilon\n", "solver.model", 2),
    ("solver max_iter", "solver:\n  max_iter: 0\n", "solver.max_iter", 2),
]


@pytest.mark.parametrize(("name", "text", "key", "line"), MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_config_names_key_file_and_line(tmp_path, name, text, key, line):
    path = tmp_path / "campaign.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_campaign(path)
    message = str(err.value)
    assert f"{path}:{line}" in message, message
    assert key in message, message


def test_unknown_key_lists_the_allowed_ones(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("algorithm:\n  pop: 10\n")
    with pytest.raises(ConfigError, match="allowed: method, population, generations, offspring, surrogate, seed"):
        load_campaign(path)


#: One key of every section of a campaign file, with a number where it takes one (``None``: no number).
EVERY_SECTION = [
    ("blade", "fixed", {"alpha": 1.0}), ("mesh", "y_plus", 1.0), ("flow", "speed", 10.0), ("solver", "alpha_u", 0.9),
    ("convergence", "max_amplitude", 0.01), ("algorithm", "population", 10), ("algorithm.crossover", "eta", 15.0),
    ("algorithm.mutation", "eta", 20.0), ("execution", "timeout", 60.0), ("execution.cluster", "cores", 1),
    ("output", "sync", None), ("analytic", "delay", 0.0),
]


def _section_text(section: str, key: str, value: str) -> str:
    """A campaign file setting ``section.key: value`` (nested sections indented)."""
    lines, indent = [], ""
    for part in section.split("."):
        lines.append(f"{indent}{part}:")
        indent += "  "
    return "\n".join([*lines, f"{indent}{key}: {value}"]) + "\n"


@pytest.mark.parametrize(("section", "key", "number"), EVERY_SECTION, ids=[s[0] for s in EVERY_SECTION])
def test_every_section_refuses_the_same_way(tmp_path, section, key, number):
    """One base (optimizer.config.Section) for every section: an unknown key names the allowed ones, a boolean
    is not a number, nan and inf are not numbers; each message names the key, the file and the line."""
    path = tmp_path / "c.yaml"
    depth = section.count(".") + 2
    path.write_text(_section_text(section, "colour", "red"))
    with pytest.raises(ConfigError, match=rf"{path}:{depth}: unknown key '{section}.colour'; allowed: .*{key}"):
        load_campaign(path)
    if number is None or isinstance(number, dict):
        return
    for value, refusal in (("true", "a number is expected, not a boolean"), (".nan", "finite number"),
                           (".inf", "finite number")):
        path.write_text(_section_text(section, key, value))
        with pytest.raises(ConfigError, match=rf"{path}:{depth}: '{section}.{key}': .*{refusal}"):
            load_campaign(path)


def test_bad_yaml_names_file_and_line(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("algorithm:\n  population: [1,\n  seed: 2\n")
    with pytest.raises(ConfigError, match=rf"{path}:\d+: not valid YAML"):
        load_campaign(path)


def test_defaults_are_the_papers_objectives():
    config = load_campaign(None)
    (fy, c_max) = config.objectives
    assert (fy.figure, fy.sense, fy.abs) == ("fy", "max", True)
    assert (c_max.figure, c_max.sense) == ("c_max", "min")
    assert config.convergence.oscillating == "accept_below_amplitude"
    assert config.convergence.max_amplitude == 0.01


def test_analytic_objectives_default_to_its_functions(tmp_path):
    path = tmp_path / "z.yaml"
    path.write_text("analytic:\n  problem: zdt1\n")
    config = load_campaign(path)
    assert [o.figure for o in config.objectives] == ["f1", "f2"]


def test_overrides_apply(tmp_path):
    config = load_campaign(None, ["algorithm.population=12", "execution.backend=inline"])
    assert config.algorithm.population == 12 and config.execution.backend == "inline"


def test_resolved_campaign_reads_back_identically(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text(textwrap.dedent("""\
        blade: {mode: toolpath, continuity: G2}
        mesh: {level: coarse, half_height: 1.0}
        objectives: [{figure: c_l, sense: max}, {figure: c_max}]
        constraints: [{figure: c_max, upper: 25}]
        algorithm: {population: 8, generations: 3, seed: 7}
        execution: {backend: inline}
        """))
    config = load_campaign(path)
    again = tmp_path / "resolved.yaml"
    again.write_text(config.to_yaml())
    assert load_campaign(again).to_yaml() == config.to_yaml()
    assert load_campaign(again).mesh_spec() == config.mesh_spec()


def test_every_shipped_campaign_config_loads():
    from pathlib import Path

    root = Path(__file__).resolve().parents[3]
    files = [root / "optimizer" / "campaign" / "quickstart.yaml", *sorted((root / "configs" / "paper").glob("*.yaml"))]
    present = [f for f in files if f.exists()]
    assert present, "no campaign configs shipped"
    for f in present:
        config = load_campaign(f)
        assert isinstance(config, CampaignConfig)


def test_yamlsource_lines_of_keys_and_items():
    data, source = parse_yaml("a:\n  b: 1\n  c:\n    - x: 2\n    - y: 3\n", "f.yaml")
    assert data == {"a": {"b": 1, "c": [{"x": 2}, {"y": 3}]}}
    assert source.where(("a", "c", 1, "y")) == "f.yaml:5"
    assert source.where(("a", "c", 1, "missing")) == "f.yaml:5"   # nearest ancestor
    assert source.where(("nowhere",)) == "f.yaml"


def test_blade_parameters_in_a_campaign_are_named_as_unused(tmp_path):
    """A campaign's designs take their values from the space: ``blade.parameters`` (a single blade's file, or
    ``--set alpha=25``) would be silently ignored, so it gets a warning that says where to put them instead."""
    import warnings

    from optimizer.campaign.config import load_campaign
    from optimizer.config import ConfigWarning

    with pytest.warns(ConfigWarning, match=r"^--set alpha=25: blade\.parameters \(alpha\) is not used by a "
                                           r"campaign.*blade\.fixed\.NAME"):
        load_campaign(None, ["alpha=25"])
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConfigWarning)
        load_campaign(None, ["blade.fixed.alpha=25"])      # the way to hold one: no warning


def test_several_unknown_keys_of_one_section_list_the_allowed_ones_once(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("algorithm:\n  pop: 10\n  gens: 3\n")
    with pytest.raises(ConfigError) as info:
        load_campaign(path)
    text = str(info.value)
    assert "unknown key 'algorithm.pop'; allowed: method, population" in text
    assert "unknown key 'algorithm.gens'; allowed: as above" in text
