"""The command line and configuration files, as a user runs them."""

import json
from pathlib import Path

import pytest

from optimizer.cli import EXIT_FAILED, EXIT_INFEASIBLE, EXIT_INPUT, EXIT_OK, main

EXAMPLES = Path(__file__).parents[2] / "configs" / "examples"


@pytest.mark.slow
def test_profile_of_each_example_writes_csv_and_plot(tmp_path, capsys):
    for name in ("table4_c2_design.yaml", "table5_g1_toolpath.yaml"):
        csv, png = tmp_path / f"{name}.csv", tmp_path / f"{name}.png"
        assert main(["profile", str(EXAMPLES / name), "--out", str(csv), "--plot", str(png)]) == EXIT_OK
        assert csv.read_text().startswith("x,y\n")
        assert png.stat().st_size > 10_000
    assert "FEASIBLE" in capsys.readouterr().out


def test_profile_without_config_uses_the_embedded_default(capsys):
    assert main(["profile", "--json"]) == EXIT_OK
    summary = json.loads(capsys.readouterr().out)
    assert summary["continuity"] == "C2" and summary["mode"] == "design" and summary["feasible"]


def test_overrides(capsys):
    assert main(["profile", str(EXAMPLES / "table5_g1_toolpath.yaml"), "--set", "d_s1=0.006",
                 "--set", "blade.parameters.d_p1=0.006", "--json"]) == EXIT_INFEASIBLE
    summary = json.loads(capsys.readouterr().out)
    assert summary["parameters"]["d_s1"] == 0.006
    assert [c["name"] for c in summary["constraints"] if not c["satisfied"]] == ["eq22_curvature"]


@pytest.mark.parametrize("argv,message", [
    (["--set", "blade.mode=milling"], "'blade.mode' = 'milling' is not allowed; allowed: 'design' or 'toolpath'"),
    (["--set", "blade.colour=red"], "unknown key 'blade.colour'; allowed: mode, continuity, parameters"),
    (["--set", "meshing.level=fine"], "unknown key 'meshing'; allowed: blade, mesh"),
    (["--set", "k2=1.0"], "unknown parameter 'k2' for a C2 design blade"),
    (["--set", "alpha"], "must look like KEY=VALUE"),
    (["missing.yaml"], "cannot read configuration file missing.yaml"),
])
def test_bad_input_is_a_clear_error(argv, message, capsys):
    config = [] if argv[0].endswith(".yaml") else [str(EXAMPLES / "table4_c2_design.yaml")]
    assert main(["profile", *argv[:1], *config, *argv[1:]] if argv[0].endswith(".yaml")
                else ["profile", *config, *argv]) == EXIT_INPUT
    assert message in capsys.readouterr().err


def test_help_lists_the_profile_command(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "profile" in capsys.readouterr().out


def test_space_lists_variables_and_fixed_values(capsys):
    argv = ["space", "--set", "blade.mode=toolpath", "--set", "blade.continuity=G2",
            "--set", "blade.bounds.R=[0.004, 0.006]", "--set", "blade.fixed.alpha=10"]
    assert main(argv) == EXIT_OK
    out = capsys.readouterr().out
    assert "G2 toolpath blades: 10 design variables" in out
    assert "[0.004, 0.006]" in out and "fixed 10" in out and "[0.008, 0.011]" in out


def test_space_of_a_campaign_file_is_the_space_its_campaign_searches(tmp_path, capsys):
    paper = EXAMPLES.parent / "paper" / "toolpath_c1.yaml"
    assert main(["space", str(paper), "--set", "blade.bounds.alpha=[0, 20]"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "C1 toolpath blades: 10 design variables" in out and "[0, 20]" in out
    analytic = tmp_path / "zdt1.yaml"
    analytic.write_text("analytic: {problem: zdt1}\n")
    assert main(["space", str(analytic)]) == EXIT_INPUT
    assert "an analytic campaign has no blade space" in capsys.readouterr().err


def test_space_overrides_are_validated(capsys):
    assert main(["space", "--set", "blade.bounds.alpha=[30, 10]"]) == EXIT_INPUT
    assert "bounds of 'alpha' must satisfy lower <= upper" in capsys.readouterr().err


@pytest.mark.slow
def test_mesh_command_writes_mesh_and_plot(tmp_path, capsys):
    msh, png = tmp_path / "blade.msh", tmp_path / "blade.png"
    argv = ["mesh", str(EXAMPLES / "table5_g1_toolpath.yaml"), "--level", "coarse", "--out", str(msh),
            "--plot", str(png), "--json"]
    assert main(argv) == EXIT_OK
    summary = json.loads(capsys.readouterr().out)
    assert summary["level"] == "coarse" and summary["cells"] == summary["quad"] + summary["triangle"]
    assert summary["quality"]["min_angle_min"] > 15 and summary["quality"]["scaled_jacobian_min"] > 0.4
    assert msh.stat().st_size > 0 and png.stat().st_size > 10_000


def test_mesh_options_are_validated(capsys):
    assert main(["mesh", "--set", "mesh.growth=1.5"]) == EXIT_INPUT
    assert "mesh.growth = 1.5 is outside [1.01, 1.2]" in capsys.readouterr().err
    assert main(["mesh", "--set", "mesh.cells=5"]) == EXIT_INPUT
    assert "unknown key 'mesh.cells'; allowed: level, upstream" in capsys.readouterr().err


def test_mesh_failure_is_exit_4_with_the_mesher_message(monkeypatch, capsys):
    import meshing
    from optimizer import pipeline

    def broken(profile, mesh_spec):
        raise meshing.MeshingError("gmsh could not recover the boundary")

    monkeypatch.setattr(pipeline, "build_mesh", broken)
    assert main(["mesh", "--level", "coarse"]) == EXIT_FAILED
    assert capsys.readouterr().err == "millfoil: mesh failed: gmsh could not recover the boundary\n"


def test_level_is_applied_over_the_configuration_as_a_typed_value():
    import argparse

    from optimizer.cli.common import load

    args = argparse.Namespace(config=EXAMPLES / "bench_g1_design.yaml", overrides=["mesh.level=fine"], level="coarse")
    assert load(args).mesh_spec().level == "coarse"
    assert load(argparse.Namespace(config=None, overrides=["mesh.level=fine"])).mesh.level == "fine"


def test_every_command_module_registers_its_commands(capsys):
    from optimizer.cli import commands

    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert all(callable(module.register) for module in commands())
    for command in ("profile", "space", "mesh", "evaluate", "validate"):
        assert command in out


def test_mesh_of_an_infeasible_blade_says_why(capsys):
    assert main(["mesh", "--set", "beta1=40"]) == EXIT_INFEASIBLE
    assert "eq21_inlet" in capsys.readouterr().err


@pytest.mark.slow
def test_validate_prints_one_json_object_per_quantity(capsys):
    assert main(["validate", "cylinder", "--json"]) == EXIT_OK
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert {r["name"].split()[0] for r in rows} >= {"C_D", "C_L"}
    assert all(set(r) == {"name", "computed", "reference", "error", "tolerance", "pass"} and r["pass"] for r in rows)


def test_validate_unknown_case(capsys):
    assert main(["validate", "airfoil"]) == EXIT_INPUT
    assert "unknown validation case 'airfoil'; allowed: cavity, cylinder, flatplate, mms, naca0012" in (
        capsys.readouterr().err)


def test_validate_alpha_only_for_the_airfoil(capsys):
    assert main(["validate", "cavity", "--alpha", "10"]) == EXIT_INPUT
    assert "--alpha applies to the naca0012 case only" in capsys.readouterr().err


# ------------------------------------------------------------------------------------- evaluate
_LAMINAR_RE20 = ["--set", "solver.model=laminar", "--set", "flow.speed=0.2", "--set", "flow.viscosity=0.9982",
                 "--set", "mesh.half_height=5", "--set", "mesh.y_plus=0.05", "--set", "solver.algorithm=simplec",
                 "--set", "solver.alpha_u=0.9", "--set", "solver.alpha_p=null", "--set", "solver.tol=1e-5"]


@pytest.mark.slow
def test_evaluate_json_and_save(tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["evaluate", str(EXAMPLES / "bench_g1_design.yaml"), "--level", "coarse", *_LAMINAR_RE20,
            "--json", "--save", str(out), "--every", "100"]
    assert main(argv) == EXIT_OK
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert summary["status"] == "converged" and summary["converged"] is True
    for key in ("F_X", "F_Y", "C_L", "C_max", "Cp_min", "yplus_max", "iterations", "cells"):
        assert isinstance(summary[key], (int, float))
    assert set(summary["seconds"]) == {"geometry", "mesh", "solve", "post"}
    assert "millfoil: solve: iteration 100/" in captured.err and "millfoil: mesh: done" in captured.err
    assert {p.name for p in out.iterdir()} == {"mesh.msh", "fields.vtu", "wall.csv", "result.json", "config.yaml"}
    assert json.loads((out / "result.json").read_text())["F_Y"] == summary["F_Y"]


def test_evaluate_exit_codes(capsys):
    bench = str(EXAMPLES / "bench_g1_design.yaml")
    assert main(["evaluate", bench, "--set", "alpha=-5", "--quiet"]) == EXIT_INFEASIBLE
    assert "FAILED at stage geometry: infeasible" in capsys.readouterr().out
    assert main(["evaluate", bench, "--set", "solver.modle=sst"]) == EXIT_INPUT
    assert "unknown key 'solver.modle'" in capsys.readouterr().err


def test_evaluate_exit_code_of_a_mesh_failure(capsys, monkeypatch):
    # A mesher failure (gmsh refusing a profile) is exit 4 at stage mesh. Configurations the mesh cannot
    # place are refused up front (exit 2), so the failure is injected where gmsh would raise it.
    import optimizer.pipeline
    from meshing import MeshingError

    def failing_mesh(profile, spec):
        raise MeshingError("gmsh could not mesh the O-layer (injected)")

    monkeypatch.setattr(optimizer.pipeline, "build_mesh", failing_mesh)
    bench = str(EXAMPLES / "bench_g1_design.yaml")
    assert main(["evaluate", bench, "--level", "coarse", "--quiet"]) == EXIT_FAILED
    assert "FAILED at stage mesh" in capsys.readouterr().out
