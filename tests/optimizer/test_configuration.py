"""Configuration files: sections, defaults, overrides, validation messages, one way to build a config."""

import dataclasses
import re
from pathlib import Path

import pytest
import yaml

from geometry import evaluate_blade
from geometry.examples import TABLE4_C2_DESIGN, TABLE5_G1_TOOLPATH
from optimizer.config import (
    SETTING_KEYS,
    SETTING_RULES,
    SETTINGS_NOT_CONFIGURED,
    SST_KEYS,
    VALIDATED_REYNOLDS,
    Config,
    ConfigError,
    SolverConfig,
    load_config,
)
from optimizer.pipeline import simple_settings
from solver import SST, SimpleSettings

EXAMPLES = Path(__file__).parents[2] / "configs" / "examples"
BENCH = EXAMPLES / "bench_g1_design.yaml"


@pytest.mark.parametrize("name,embedded", [("table4_c2_design.yaml", TABLE4_C2_DESIGN),
                                           ("table5_g1_toolpath.yaml", TABLE5_G1_TOOLPATH)])
def test_shipped_examples_match_the_embedded_tables(name, embedded):
    blade = yaml.safe_load((EXAMPLES / name).read_text())["blade"]
    assert blade == embedded


def test_bench_example_is_the_g1_design_blade():
    raw = yaml.safe_load(BENCH.read_text())
    assert raw["blade"]["mode"] == "design" and raw["blade"]["continuity"] == "G1"
    assert raw["mesh"]["half_height"] == 1.0
    assert evaluate_blade(load_config(BENCH).blade.blade_spec()).feasible


def test_a_file_without_parameters_reports_the_missing_ones(tmp_path):
    path = tmp_path / "blade.yaml"
    path.write_text("blade:\n  mode: toolpath\n  continuity: G2\n")
    with pytest.raises(ConfigError, match="missing parameters 'alpha', 'beta1'"):
        load_config(path)


def test_table4_parameters_are_the_default_of_a_blade_that_names_no_family():
    assert load_config().blade.parameters == TABLE4_C2_DESIGN["parameters"]
    changed = load_config(overrides=["alpha=20"]).blade.parameters
    assert changed == {**TABLE4_C2_DESIGN["parameters"], "alpha": 20}
    # the same rule whichever way the configuration is built (the robustness bench builds from a mapping)
    for raw in ({}, {"blade": {"parameters": {"alpha": 20}}}, {"blade": {"mode": "toolpath", "continuity": "G1"}}):
        assert Config.model_validate(raw) == Config.from_mapping(raw, blade_values=False)
    assert Config.model_validate({"blade": {"mode": "toolpath"}}).blade.parameters == {}


def test_typed_values_are_set_after_the_overrides():
    config = load_config(BENCH, ["mesh.level=fine", "alpha=10"], values={"mesh.level": "coarse", "beta1": 1.5})
    assert config.mesh.level == "coarse" and config.mesh_spec().level == "coarse"
    assert config.blade.parameters["alpha"] == 10 and config.blade.parameters["beta1"] == 1.5


def test_a_subclass_with_more_sections_loads_the_same_way(tmp_path):
    class Extended(Config):
        extra: dict[str, int] = {}

    path = tmp_path / "c.yaml"
    path.write_text("extra: {a: 1}\nflow: {speed: 2.0}\n")
    config = load_config(path, ["extra.b=2"], schema=Extended)
    assert isinstance(config, Extended) and config.extra == {"a": 1, "b": 2} and config.flow.speed == 2.0
    with pytest.raises(ConfigError, match="unknown key 'extras'; allowed: blade, mesh, flow, solver, extra"):
        load_config(overrides=["extras.a=1"], schema=Extended)


def test_flow_section_drives_the_mesh_unless_the_mesh_sets_it():
    c = load_config(BENCH, ["flow.speed=2", "flow.viscosity=2e-3", "flow.density=1000"])
    assert c.mesh_spec().flow_speed == 2 and c.mesh_spec().viscosity == pytest.approx(2e-6)
    c = load_config(BENCH, ["flow.speed=2", "mesh.flow_speed=5"])
    assert c.mesh_spec().flow_speed == 5
    assert load_config(BENCH).flow.span_for(0.1) == pytest.approx(0.004)
    assert load_config(BENCH, ["flow.span=0.01"]).flow.span_for(0.1) == 0.01


@pytest.mark.parametrize("override,message", [
    ("flow.sped=3", "unknown key 'flow.sped'; allowed: speed, density"),
    ("solver.model=kepsilon", "'solver.model' = 'kepsilon' is not allowed"),
    ("flow.intensity=2", "'flow.intensity'"),
    ("solver.wall_treatment=wallfn", "allowed: 'automatic' or 'low_re'"),
    ("solver.omega_production=clipped", "allowed: 'unlimited' or 'limited'"),
    ("solver.omega_wall_flux=wall_function", "allowed: 'analytic' or 'two_point'"),
    ("solver.sst_velocity_gradient=gauss", "allowed: 'least_squares', 'green_gauss' or 'green_gauss_bounded'"),
    ("solver.alpha_u=1.5", "'solver.alpha_u' = 1.5 is outside (0, 1]: an under-relaxation factor"),
    ("solver.max_iter=0", "'solver.max_iter' = 0 is outside [1, 100000]: the blade solves converge in"),
    ("solver.algorithm=piso", "'solver.algorithm' = 'piso' is not allowed; allowed: 'simple' or 'simplec'"),
    ("solver.initial=potentail", "'solver.initial' = 'potentail' is not allowed; allowed: 'freestream', 'rest' or "
     "'potential'"),
])
def test_flow_and_solver_sections_are_validated(override, message):
    with pytest.raises(ConfigError, match=re.escape(message)):
        load_config(BENCH, [override])


def test_the_potential_start_is_a_choice_of_the_solver_section():
    assert load_config(BENCH, ["solver.initial=potential"]).solver.initial == "potential"


def test_saved_config_reads_back_the_same():
    config = load_config(BENCH, ["solver.max_iter=30", "mesh.level=coarse"])
    again = Config.from_mapping(yaml.safe_load(config.to_yaml()))
    assert again.mesh_spec() == config.mesh_spec() and again.flow == config.flow and again.solver == config.solver
    assert again.blade == config.blade



def test_solver_settings_are_the_solvers_own_with_the_blade_monitored():
    settings = simple_settings(load_config())
    assert settings == SimpleSettings.for_blades(monitor_groups=("blade",), stop_monitors=("fy:blade", "c_max"))
    changed = simple_settings(load_config(overrides=["solver.alpha_u=0.5", "solver.max_iter=7"]))
    assert (changed.alpha_u, changed.max_iter) == (0.5, 7)


def test_solver_section_defaults_are_the_solvers_blade_defaults():
    """The ``solver:`` section's defaults are :meth:`solver.SimpleSettings.for_blades` and
    :meth:`solver.turbulence.SST.for_blades`: one definition, in the solver. The blade evaluations differ from
    the solver's general defaults where their decision records say so (docs/decisions/0001-0004)."""
    blades = SimpleSettings.for_blades()
    assert SolverConfig().settings() == {k: getattr(blades, k) for k in SETTING_KEYS}
    assert SolverConfig().sst_settings() == {name: getattr(SST.for_blades(), name) for name, _ in SST_KEYS.values()}
    general = SimpleSettings()
    assert {k for k in SETTING_KEYS if getattr(blades, k) != getattr(general, k)} == {
        "pressure_gradient", "face_velocity", "alpha_p", "startup_alpha_p_iterations", "limiter_k"}
    assert (blades.pressure_gradient, blades.face_velocity, blades.alpha_p, blades.startup_alpha_p_iterations,
            blades.limiter_k) == ("green_gauss_bounded", "bounded", 0.7, 150, 100.0)
    assert SST.for_blades() == dataclasses.replace(SST(), omega_production="limited")
    assert SST().omega_production == "unlimited"
    fields = {f.name for f in dataclasses.fields(SimpleSettings)}
    # every field is a key of the section or is left out for a stated reason
    assert fields == set(SETTING_KEYS) | set(SETTINGS_NOT_CONFIGURED)
    assert set(SETTING_RULES) <= set(SETTING_KEYS)


def test_every_key_of_every_section_has_one_description_from_its_owner():
    """Every key of the schema carries a description (the generated configuration reference prints it);
    a solver key's is the solver's own field description, a mesh key's the MeshSpec field's."""
    from meshing.spec import FIELD_DOCS
    from optimizer.campaign.config import CampaignConfig
    from solver.settings import setting_doc

    schema = CampaignConfig.model_json_schema()
    for name, section in [("campaign", schema), *schema["$defs"].items()]:
        for key, prop in section.get("properties", {}).items():
            assert prop.get("description"), f"{name}.{key}"
    solver = SolverConfig.model_json_schema()["properties"]
    for key in SETTING_KEYS:
        assert solver[key]["description"] == setting_doc(SimpleSettings, key)
    for key, (name, _) in SST_KEYS.items():
        assert solver[key]["description"] == setting_doc(SST, name)
    mesh = Config.model_json_schema()["$defs"]["MeshConfig"]["properties"]
    assert all(mesh[key]["description"].startswith(FIELD_DOCS[key]) for key in FIELD_DOCS)


def test_solver_section_choices_are_the_solver_registries():
    from solver.assembly import CONVECTION_SCHEMES
    from solver.gradient import LIMITERS
    from solver.pressure import FACE_VELOCITIES
    from solver.simple import ALGORITHMS, PRESSURE_GRADIENTS
    from solver.turbulence import (
        MODELS,
        OMEGA_PRODUCTIONS,
        OMEGA_WALL_FLUXES,
        VELOCITY_GRADIENTS,
        WALL_TREATMENTS,
    )
    from solver.warmstart import INITIAL_FIELDS

    registries = {"algorithm": ALGORITHMS, "convection": CONVECTION_SCHEMES, "limiter": LIMITERS,
                  "pressure_gradient": PRESSURE_GRADIENTS, "face_velocity": FACE_VELOCITIES}
    for key, registry in registries.items():
        assert SETTING_RULES[key]["choices"] == tuple(registry), key
    text_keys = {k for k in SETTING_KEYS if isinstance(getattr(SimpleSettings(), k), str)}
    assert text_keys == set(registries)
    schema = SolverConfig.model_json_schema()["properties"]
    for key, registry in {**registries, "model": MODELS, "initial": INITIAL_FIELDS,
                          "wall_treatment": WALL_TREATMENTS, "omega_production": OMEGA_PRODUCTIONS,
                          "omega_wall_flux": OMEGA_WALL_FLUXES, "sst_velocity_gradient": VELOCITY_GRADIENTS}.items():
        assert schema[key]["enum"] == list(registry), key
    assert set(VALIDATED_REYNOLDS) == set(MODELS)


@pytest.mark.parametrize("override,message", [
    ("solver.limiter=minmod", "'solver.limiter' = 'minmod' is not allowed; allowed: "),
    ("solver.divergence_factor=0.5", "'solver.divergence_factor' = 0.5 is outside (1, 1e+12]"),
    ("solver.momentum_solver=amg", "unknown key 'solver.momentum_solver'; allowed: model, wall_treatment, "
                                   "omega_production, omega_wall_flux, sst_velocity_gradient, initial"),
    ("solver.alpha_p=0", "'solver.alpha_p' = 0 is outside (0, 1]"),
    ("solver.green_gauss_relaxation=0", "'solver.green_gauss_relaxation' = 0 is outside (0, 1]"),
    ("solver.pressure_gradient=gauss",
     "allowed: 'least_squares', 'green_gauss', 'green_gauss_bounded' or 'green_gauss_linear'"),
    ("solver.face_velocity=clipped",
     "'solver.face_velocity' = 'clipped' is not allowed; allowed: 'corrected' or 'bounded'"),
])
def test_generated_solver_keys_are_validated_with_the_key_named(override, message):
    with pytest.raises(ConfigError, match=re.escape(message)):
        load_config(overrides=[override])
    assert load_config(overrides=["solver.Limiter=Barth_Jespersen".lower()]).solver.limiter == "barth_jespersen"
    assert load_config(overrides=["solver.alpha_p=null"]).solver.alpha_p is None


def test_every_section_is_on_the_one_frozen_base():
    """Every section model reachable from the campaign schema derives from :class:`optimizer.config.Section`
    (frozen, unknown keys, booleans and non-finite numbers refused the same way)."""
    import typing

    from pydantic import BaseModel

    from optimizer.campaign.config import CampaignConfig
    from optimizer.config import Section

    seen, todo = set(), [CampaignConfig]
    while todo:
        model = todo.pop()
        if model in seen:
            continue
        seen.add(model)
        assert issubclass(model, Section), model.__name__
        for info in model.model_fields.values():
            args = [info.annotation, *typing.get_args(info.annotation)]
            args += [a for arg in list(args) for a in typing.get_args(arg)]
            todo += [a for a in args if isinstance(a, type) and issubclass(a, BaseModel)]
    assert {m.__name__ for m in seen} >= {"BladeConfig", "MeshConfig", "FlowConfig", "SolverConfig", "Objective",
                                          "FigureConstraint", "ConvergencePolicy", "AlgorithmConfig", "Crossover",
                                          "Mutation", "ExecutionConfig", "ClusterOptions", "OutputConfig",
                                          "AnalyticConfig"}
