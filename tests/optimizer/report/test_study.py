"""The report's "Paper study" (:mod:`optimizer.report.study`) without CFD: the pairing of the G1 fronts, each
claim's verdict on constructed values (holds, does not hold, cannot tell), the section present only with
two or more of the paper's cases, and the page still written whole or not at all.

The claim and pairing tests build points in memory (the values are made up to sit on either side of each
rule's threshold); the page tests use synthetic stores (:mod:`optimizer.report.synthetic`) and draw figures
for seconds, so they are marked slow."""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from optimizer.campaign.status import EvaluationStatus
from optimizer.campaign.store import CampaignRow, EvaluationRow
from optimizer.report.analysis import Point
from optimizer.report.run import Design, Run, load_run
from optimizer.report.study import (
    StudyLevel,
    Verdict,
    claim_c2_lift,
    claim_cmax_toolpath,
    claim_lift_difference,
    claims,
    is_study,
    mesh_dependence,
    normaliser,
    pair_fronts,
    spread,
    study_levels,
    study_order,
    table7_rows,
)
from optimizer.report.synthetic import synthetic_run
from solver.convergence import ConvergenceClass

PAPER_OBJECTIVES = [{"figure": "fy", "sense": "max", "abs": True}, {"figure": "c_max", "sense": "min"}]
_numbers = iter(range(1, 10_000))


def fake_run(mode: str, continuity: str, level: str = "coarse", objectives=PAPER_OBJECTIVES) -> Run:
    """A run that exists only in memory: its configuration names the case; it holds no designs."""
    campaign = CampaignRow("", 0, "0", "2026-01-01", None, "finished", None, "made up")
    config = {"blade": {"mode": mode, "continuity": continuity}, "mesh": {"level": level}, "objectives": objectives}
    return Run(Path(f"{mode}_{continuity}_{level}"), campaign, config, ())


def point(fy: float = 80.0, cmax: float = 12.0, cl: float | None = None, cpmin: float | None = None, *,
          dfy: float = 0.0, dcmax: float = 0.0, status: str = "ok") -> Point:
    """A made-up design: |F_Y| (N), C_max (m/s); C_L and |C_p,min| follow from them unless given; an
    amplitude makes it an oscillating design."""
    oscillating = dfy > 0 or dcmax > 0
    row = EvaluationRow(key=f"{next(_numbers):064x}", generation=0, x=[], parameters={}, status=status, reason="",
                        minimised=[-fy, cmax], constraints={"c": -1.0},
                        convergence=ConvergenceClass.OSCILLATING if oscillating else ConvergenceClass.CONVERGED)
    number = next(_numbers)
    return Point(Design(number, row), fy, fy / 20.0 if cl is None else cl, cmax,
                 cmax**2 / 100.0 - 1.0 if cpmin is None else cpmin, dfy=dfy, dcmax=dcmax)


def level_of(values: dict[tuple[str, str], list[Point]], level: str = "coarse") -> StudyLevel:
    return StudyLevel(level, {c: (fake_run(*c, level), pts) for c, pts in values.items()})


# ------------------------------------------------------------------------------------------- pairing
def test_spread_takes_the_ends_and_distinct_designs():
    f = [point(cl=3.0 + 0.1 * k, cpmin=0.4 + 0.01 * k**2) for k in range(12)]
    chosen = spread(f, 6, normaliser(f))
    assert len(chosen) == 6 == len({p.design.number for p in chosen})
    assert chosen[0] is f[0] and chosen[-1] is f[-1]
    assert spread(f[:4], 6, normaliser(f)) == f[:4]


def test_pairing_picks_the_nearest_distinct_designs():
    """Two design points share the same nearest tool-path point: the closer one gets it, the other the next
    nearest; no tool-path design is used twice, and every pair is nearest among what was left."""
    design = [point(cl=3.0, cpmin=0.40), point(cl=3.5, cpmin=0.45), point(cl=3.52, cpmin=0.452),
              point(cl=4.0, cpmin=0.50)]
    toolpath = [point(cl=3.02, cpmin=0.401), point(cl=3.51, cpmin=0.451), point(cl=3.6, cpmin=0.46),
                point(cl=3.98, cpmin=0.499), point(cl=4.4, cpmin=0.6)]
    pairs = pair_fronts(design, toolpath, count=6)
    assert [p.design for p in pairs] == design                      # four points: all of them, in order
    got = [p.toolpath for p in pairs]
    assert got == [toolpath[0], toolpath[1], toolpath[2], toolpath[3]]
    assert len({p.design.number for p in got}) == len(got)
    scale = normaliser(design + toolpath)
    taken: set[int] = set()
    for pair in sorted(pairs, key=lambda p: p.distance):
        left = [t for t in toolpath if t.design.number not in taken]
        nearest = min(left, key=lambda t: np.linalg.norm(scale(t) - scale(pair.design)))
        assert pair.toolpath is nearest
        assert pair.distance == pytest.approx(np.linalg.norm(scale(nearest) - scale(pair.design)))
        taken.add(pair.toolpath.design.number)


def test_pairing_with_a_shorter_tool_path_front():
    design = [point(cl=3.0 + 0.2 * k, cpmin=0.4 + 0.02 * k) for k in range(6)]
    pairs = pair_fronts(design, [point(cl=3.41, cpmin=0.44)])
    assert [p.toolpath is not None for p in pairs].count(True) == 1
    assert pairs[2].toolpath is not None and pairs[0].toolpath is None and pairs[0].distance is None


# -------------------------------------------------------------------------------------------- claims
def every_class(g1_design: Point | None = None, g1_toolpath: Point | None = None,
                given: dict[tuple[str, str], Point] | None = None, **others: float) -> StudyLevel:
    """The eight cases, one design each: G1's two and those in ``given`` as given, the others at ``others``
    (``fy=``, ``cmax=``)."""
    given = {("design", "G1"): g1_design, ("toolpath", "G1"): g1_toolpath, **(given or {})}
    return level_of({(m, k): [given.get((m, k)) or point(**others)] for m in ("design", "toolpath")
                     for k in ("G1", "C1", "G2", "C2")})


def test_claim_a_lift_difference():
    holds = every_class(point(80.0), point(82.0))
    assert claim_lift_difference(holds).verdict == Verdict.HOLDS               # 2.4 % < 4 %
    # the same with a class missing: "always" is not shown
    assert claim_lift_difference(level_of({("design", "G1"): [point(80.0)], ("toolpath", "G1"): [point(82.0)]})
                                 ).verdict == Verdict.CANNOT_TELL
    fails = level_of({("design", "G1"): [point(80.0)], ("toolpath", "G1"): [point(82.0)],
                      ("design", "C1"): [point(80.0)], ("toolpath", "C1"): [point(90.0)]})
    claim = claim_lift_difference(fails)
    assert claim.verdict == Verdict.FAILS                                      # C1: 11 %
    assert "C1 11.1 %" in claim.ours and len(claim.used) == 4
    # 3.2 N of 83.2 N (3.8 %) with ±1 N on the tool-path design: anywhere from 2.6 % to 5.0 %
    marginal = every_class(point(80.0), point(83.2, dfy=1.0))
    claim = claim_lift_difference(marginal)
    assert claim.verdict == Verdict.CANNOT_TELL
    assert any("oscillating ±1 N" in u.convergence for u in claim.used)
    # 3.0 N of 83 N (3.6 %) with ±0.05 N and the steady designs' 10⁻³: 3.4 % to 3.8 %, decided
    assert claim_lift_difference(every_class(point(80.0), point(83.0, dfy=0.05))).verdict == Verdict.HOLDS
    # steady designs: within the stop test's 10⁻³ of 4 % (3.96 % ± 0.2 %) cannot tell
    assert claim_lift_difference(every_class(point(80.0), point(83.3))).verdict == Verdict.CANNOT_TELL
    # no class with both approaches
    alone = level_of({("design", "G1"): [point(80.0)], ("toolpath", "C1"): [point(80.0)]})
    assert claim_lift_difference(alone).verdict == Verdict.CANNOT_TELL


def test_claim_a_names_an_excluded_design_beyond_the_maximum():
    rejected = point(95.0, dfy=6.0, status=EvaluationStatus.OSCILLATING)
    level = level_of({("design", "G1"): [point(80.0), rejected], ("toolpath", "G1"): [point(81.0)]})
    claim = claim_lift_difference(level)
    design = next(u for u in claim.used if u.case == "G1 design")
    assert design.value == 80.0 and design.beyond[0] == rejected.design.number
    assert "excluded" in design.describe() and "excluded (oscillating)" in design.beyond[1]


def test_claim_b_cmax_greater_for_the_tool_path():
    above = {("toolpath", k): point(cmax=12.2) for k in ("C1", "G2", "C2")}     # 0.2 m/s above the designs
    holds = every_class(point(cmax=12.1), point(cmax=12.3), above, cmax=12.0)
    assert claim_cmax_toolpath(holds).verdict == Verdict.HOLDS
    fails = level_of({("design", "G1"): [point(cmax=12.1)], ("toolpath", "G1"): [point(cmax=12.0)]})
    assert claim_cmax_toolpath(fails).verdict == Verdict.FAILS
    # steady designs 0.01 m/s apart: within the stop test's 10⁻³ of each (±0.024 m/s together)
    equal = every_class(point(cmax=12.1), point(cmax=12.09), above, cmax=12.0)
    assert claim_cmax_toolpath(equal).verdict == Verdict.CANNOT_TELL
    marginal = level_of({("design", "G1"): [point(cmax=12.1)], ("toolpath", "G1"): [point(cmax=12.12, dcmax=0.05)]})
    assert claim_cmax_toolpath(marginal).verdict == Verdict.CANNOT_TELL
    assert claim_cmax_toolpath(level_of({("design", "G1"): [point()]})).verdict == Verdict.CANNOT_TELL


def test_claim_c_c2_lift_about_15_percent_lower():
    def cases(c2_design: float, c2_toolpath: float | None, **amplitude) -> StudyLevel:
        values = {("design", "G1"): [point(84.0)], ("design", "G2"): [point(88.0)],
                  ("design", "C2"): [point(c2_design, **amplitude)], ("toolpath", "G1"): [point(88.0)]}
        if c2_toolpath is not None:
            values[("toolpath", "C2")] = [point(c2_toolpath)]
        return level_of(values)

    claim = claim_c2_lift(cases(74.8, 75.0))                                 # 15.0 % and 14.8 %
    assert claim.verdict == Verdict.HOLDS
    assert "design 15.0 % (C2 vs G2)" in claim.ours and "C2 vs G2" in claim.paper
    assert {u.case for u in claim.used} == {"C2 design", "G2 design", "C2 tool path", "G1 tool path"}
    assert claim_c2_lift(cases(86.0, 75.0)).verdict == Verdict.FAILS           # design: 2.3 %
    assert claim_c2_lift(cases(74.8, None)).verdict == Verdict.CANNOT_TELL     # one approach cannot show both
    assert claim_c2_lift(cases(86.0, None)).verdict == Verdict.FAILS           # ... but can show it fails
    assert claim_c2_lift(cases(79.5, 75.0, dfy=2.0)).verdict == Verdict.CANNOT_TELL   # 9.7 %, 7.4 % to 12 %
    assert claim_c2_lift(level_of({("design", "G1"): [point(84.0)]})).verdict == Verdict.CANNOT_TELL


def test_paper_table7_as_the_claims_read_it():
    """The paper's column applies each test to Table 7 itself: its G1 lift difference is 4.6 %, its C2 drops
    11.3 % (design) and 13.3 % (tool path)."""
    level = level_of({(m, k): [point()] for m in ("design", "toolpath") for k in ("G1", "C1", "G2", "C2")})
    assert "G1 4.6 %" in claim_lift_difference(level).paper
    assert claim_c2_lift(level).paper.startswith("design 11.3 % (C2 vs G2); tool path 13.3 % (C2 vs G1)")


def test_claims_per_mesh_level_and_the_first_run_of_a_case():
    runs = [fake_run("design", "G1", "coarse"), fake_run("toolpath", "G1", "coarse"),
            fake_run("design", "G1", "medium"), fake_run("toolpath", "G1", "medium"),
            dataclasses.replace(fake_run("design", "G1", "coarse"), directory=Path("again"))]
    pts = [[point(80.0)], [point(81.0)], [point(80.0)], [point(95.0)], [point(60.0)]]
    levels = study_levels(runs, pts)
    assert [lv.level for lv in levels] == ["coarse", "medium"] and levels[0].ignored == ("again",)
    found = claims(runs, pts)
    assert [(c.key, c.level) for c in found] == [(k, lv) for lv in ("coarse", "medium") for k in "abc"]
    # coarse: G1 holds, the other classes are missing; medium: G1 fails, which no other class can undo
    assert found[0].verdict == Verdict.CANNOT_TELL and found[0].ours.startswith("G1 1.2 %")
    assert found[3].verdict == Verdict.FAILS


def test_claims_leave_out_a_run_that_has_not_finished():
    """A medium run still going has a partial front: the claims are tested on the finished runs only, so the
    medium G1 pair, 80 against 95 N, does not count (with it, claim (a) would fail), while Table 7 lists
    every run."""
    running = fake_run("toolpath", "G1", "medium")
    running = dataclasses.replace(running, campaign=dataclasses.replace(running.campaign, state="running"))
    runs = [fake_run("design", "G1", "coarse"), fake_run("toolpath", "G1", "coarse"),
            fake_run("design", "G1", "medium"), running]
    pts = [[point(80.0)], [point(81.0)], [point(80.0)], [point(95.0)]]
    verdicts = {(c.key, c.level): c.verdict for c in claims(runs, pts)}
    assert verdicts["a", "medium"] == Verdict.CANNOT_TELL                      # no pair: nothing tested
    assert len(table7_rows(runs, pts)) == 4


def test_mesh_dependence_reads_both_fronts_at_common_bounds():
    """Coarse front: C_max 11, 12, 14 m/s with 10, 30, 50 N; medium: 11.5, 13, 15 m/s with 12, 36, 60 N. The
    bounds run from 11.5 (the higher lowest C_max) to 14 (the lower C_max at maximum lift); at each, the best
    lift within it. A dominated design and a case at one level only are not read; an unfinished run is left
    out as for the claims."""
    coarse = [point(10.0, 11.0), point(30.0, 12.0), point(50.0, 14.0), point(20.0, 13.0)]
    medium = [point(12.0, 11.5), point(36.0, 13.0), point(60.0, 15.0)]
    runs = [fake_run("design", "G1", "coarse"), fake_run("design", "G1", "medium"), fake_run("design", "C2", "coarse")]
    pts = [coarse, medium, [point(40.0, 12.0)]]
    [m] = mesh_dependence(runs, pts, count=6)
    assert m.case == ("design", "G1") and m.levels == ("coarse", "medium")
    assert m.bounds == pytest.approx((11.5, 12.0, 12.5, 13.0, 13.5, 14.0))
    assert [(a.fy, f.fy) for a, f in m.best] == [(10, 12), (30, 12), (30, 12), (30, 36), (30, 36), (50, 36)]
    assert m.gap(0) == pytest.approx(2.0) and m.difference(0) == pytest.approx(0.2)
    assert m.gap(5) == pytest.approx(-14.0) and m.difference(5) == pytest.approx(-0.28)
    unfinished = dataclasses.replace(runs[1], campaign=dataclasses.replace(runs[1].campaign, state="running"))
    assert mesh_dependence([runs[0], unfinished, runs[2]], pts) == []


def test_mesh_dependence_table_and_csv(tmp_path):
    from optimizer.report.html import _study_mesh

    runs = [fake_run("toolpath", "C1", "coarse"), fake_run("toolpath", "C1", "medium")]
    pts = [[point(40.0, 12.0), point(50.0, 14.0)], [point(44.0, 12.0, dfy=1.5), point(55.0, 14.0)]]
    files = {}
    html = _study_mesh(runs, pts, files)
    assert "Mesh dependence" in html and "C1 tool path" in html and "oscillating ±1.5 N" in html
    files["mesh_dependence.csv"](tmp_path / "m.csv")
    rows = list(csv.DictReader(open(tmp_path / "m.csv")))
    assert len(rows) == 6 and rows[0]["coarser_level"] == "coarse" and rows[0]["finer_level"] == "medium"
    assert float(rows[0]["c_max_bound"]) == 12.0 and float(rows[0]["gap_N"]) == pytest.approx(4.0)
    assert float(rows[0]["relative"]) == pytest.approx(0.1)
    assert float(rows[-1]["finer_fy_span_N"]) == 55.0 and rows[-1]["coarser_class"] == "steady"
    assert _study_mesh(runs[:1], pts[:1], {}) == ""


def test_a_study_needs_two_paper_cases():
    g1, tp = fake_run("design", "G1"), fake_run("toolpath", "G1")
    other = fake_run("design", "G1", objectives=[{"figure": "c_l", "sense": "max"}, {"figure": "c_max",
                                                                                        "sense": "min"}])
    assert is_study([g1, tp]) and is_study([g1, tp, other])
    assert not is_study([g1]) and not is_study([g1, g1]) and not is_study([g1, other])
    rows = table7_rows([g1, other], [[point(84.14 * 1.1)], [point()]])
    assert len(rows) == 1 and rows[0].relative("fy") == pytest.approx(0.1)


# ---------------------------------------------------------------------------------------------- page
def design_g1(run: Run) -> Run:
    """A synthetic tool-path G1 run relabelled as a G1 design run (its blades without the cutter radius R,
    so the gallery rebuilds them as designed blades); only for the report's tests."""
    config = {**run.config, "blade": {**run.config["blade"], "mode": "design", "continuity": "G1"}}
    designs = tuple(Design(d.number, dataclasses.replace(d.row, parameters={k: v for k, v in
                    d.row.parameters.items() if k != "R"})) for d in run.designs)
    return dataclasses.replace(run, config=config, designs=designs)


@pytest.fixture(scope="module")
def study_runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("study")
    toolpath = load_run(synthetic_run(base / "toolpath_g1", population=8, generations=3, seed=1, fields=3))
    design = design_g1(load_run(synthetic_run(base / "design_g1", population=8, generations=3, seed=3, fields=3)))
    c2 = load_run(synthetic_run(base / "design_c2", mode="design", population=6, generations=3, seed=2))
    return base, [design, toolpath, c2]


@pytest.fixture(scope="module")
def study_report(study_runs):
    from optimizer.report.html import write_report

    base, runs = study_runs
    return write_report(runs, base / "report").parent


@pytest.mark.slow
def test_study_section_and_its_files(study_runs, study_report):
    page = (study_report / "index.html").read_text()
    assert 'id="study"' in page and 'href="#study"' in page
    section = page[page.index('id="study"'):page.index('id="gallery"')]
    for name in ("table7.csv", "claims.csv", "study_fronts.svg", "g1_pairs_0.svg", "g1_pairs_0.csv"):
        assert f'"{name}"' in section and (study_report / name).stat().st_size > 100, name
    table = list(csv.DictReader(open(study_report / "table7.csv")))
    assert [(t["mode"], t["continuity"], t["mesh_level"]) for t in table] == [      # Table 7's order
        ("design", "G1", "medium"), ("design", "C2", "medium"), ("toolpath", "G1", "medium")]
    tp = table[2]
    assert float(tp["fy_paper"]) == 88.16
    assert float(tp["fy_relative"]) == pytest.approx(float(tp["fy"]) / 88.16 - 1.0)
    assert int(tp["cfd_evaluations"]) == sum(d.row.status != "infeasible" for d in study_runs[1][1].designs)
    verdicts = {r["claim"]: r["verdict"] for r in csv.DictReader(open(study_report / "claims.csv"))}
    assert set(verdicts) == {"a", "b", "c"} and set(verdicts.values()) <= {v.value for v in Verdict}
    pairs = list(csv.DictReader(open(study_report / "g1_pairs_0.csv")))
    assert 1 <= len(pairs) <= 6
    used = [p["toolpath_number"] for p in pairs if p["toolpath_number"]]
    assert len(used) == len(set(used))


def test_fig9_names_each_case_and_mesh_level(study_runs):
    from optimizer.report.analysis import points
    from optimizer.report.study import case_colour, fronts_by_case

    _, runs = study_runs
    fronts = fronts_by_case(runs, [points(r) for r in runs])
    assert [label for label, *_ in fronts] == ["G1 design (medium)", "G1 tool path (medium)", "C2 design (medium)"]
    assert len({case_colour(c) for _, c, _, _ in fronts}) == 3
    for *_, f in fronts:
        assert f and all(a.cpmin <= b.cpmin and a.cl < b.cl for a, b in zip(f, f[1:], strict=False))


@pytest.mark.slow
def test_no_study_section_with_one_paper_case(study_runs, tmp_path):
    from optimizer.report.html import write_report

    _, runs = study_runs
    page = write_report([runs[1]], tmp_path / "one").read_text()
    assert 'id="study"' not in page and "Paper study" not in page
    assert not (tmp_path / "one" / "table7.csv").exists()


@pytest.mark.slow
def test_a_failing_study_figure_leaves_the_previous_report(study_runs, tmp_path, monkeypatch):
    """The study's files join the page's one write: a figure that cannot be drawn leaves no new file and the
    previous report as it was."""
    from optimizer.report import html
    from optimizer.saving import WriteFailure

    _, runs = study_runs
    out = tmp_path / "report"
    out.mkdir()
    (out / "index.html").write_text("previous report")

    def broken(*args, **kwargs):
        raise RuntimeError("cannot draw")

    monkeypatch.setattr(html, "study_pairs_figure", broken)
    with pytest.raises(WriteFailure, match="cannot draw"):
        html.write_report(runs, out)
    assert sorted(p.name for p in out.iterdir()) == ["index.html"]
    assert (out / "index.html").read_text() == "previous report"


def test_the_fields_the_report_draws_are_enough_to_draw_it_again(study_runs, tmp_path):
    """A copy of the runs that keeps only `fields_shown`'s files (as the repository keeps its examples) has
    the same designs drawn in the Flow fields section, and every G1 pair keeps the files it had."""
    import shutil

    from optimizer.campaign.fields import fields_path
    from optimizer.report.analysis import fields_designs, points
    from optimizer.report.html import fields_shown
    from optimizer.report.study import g1_pairs, kept_fields, study_levels

    _, runs = study_runs
    shown = fields_shown(runs)
    copies = []
    for k, run in enumerate(runs):
        copy = tmp_path / f"run{k}"
        for key in shown[run.directory]:
            assert fields_path(run.directory, key).is_file()
            fields_path(copy, key).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(fields_path(run.directory, key), fields_path(copy, key))
        copies.append(dataclasses.replace(run, directory=copy))
    pts = [points(r) for r in runs]
    for run, copy, p in zip(runs, copies, pts, strict=True):
        drawn = [[q.design.key for q, _ in fields_designs(r, p)[0]] for r in (run, copy)]
        assert drawn[0] == drawn[1]
    pairs = [g for lv in study_levels(runs, pts) if (g := g1_pairs(lv)) is not None]
    copied = [g for lv in study_levels(copies, pts) if (g := g1_pairs(lv)) is not None]
    assert pairs and len(pairs) == len(copied)
    for g, c in zip(pairs, copied, strict=True):
        for a, b in zip(g.pairs, c.pairs, strict=True):
            assert (kept_fields(g.design, a.design) is None) == (kept_fields(c.design, b.design) is None)


def test_steady_tolerance_is_the_solvers_stop_and_stationary_tolerance():
    """A steady design's figure is trusted to the accuracy the solver's defaults give it; should they change,
    the verdicts' steady uncertainty must follow."""
    from optimizer.report.study import STEADY_TOLERANCE
    from solver.settings import SimpleSettings

    assert SimpleSettings().stop_tol == SimpleSettings().classify_tol == STEADY_TOLERANCE


def test_study_order_is_table_7s_by_mesh_level_with_other_runs_last():
    runs = [fake_run("toolpath", "G1", "medium"), fake_run("design", "C2", "coarse"),
            fake_run("design", "G1", "medium"), fake_run("toolpath", "G1", "coarse"),
            dataclasses.replace(fake_run("design", "G1", "coarse"), config={"blade": {"mode": "design"}}),
            fake_run("design", "G1", "coarse"), fake_run("design", "G1", "fine")]
    assert study_order(runs) == [5, 1, 3, 2, 0, 6, 4]
