"""``millfoil report`` on made-up stores (no CFD): the page, its figures and tables, the Table 7 summary
against values computed here from the store rows, escaping, a running campaign, and a real headless
browser rendering the page. Drawing the figures takes seconds (matplotlib): the tests that write a page are
marked slow; the fast tier checks what the page is computed from."""

from __future__ import annotations

import csv
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from optimizer.campaign.store import STORE_NAME, Store
from optimizer.cli import main
from optimizer.report.run import load_run
from optimizer.report.synthetic import synthetic_run

EVIL = '<img src=x onerror="alert(1)">&'


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("runs")
    a = synthetic_run(base / "toolpath_g1", population=6, generations=3, seed=1, fields=2)
    b = synthetic_run(base / EVIL, population=5, generations=2, seed=2, finished=False)
    return a, b


@pytest.fixture(scope="module")
def report(runs):
    out = runs[0] / "report"
    assert main(["report", str(runs[0]), str(runs[1])]) == 0
    return out


@pytest.mark.slow
def test_page_and_every_file_it_names(report):
    page = (report / "index.html").read_text()
    sources = re.findall(r'(?:src|href)="([^"#]+)"', page)
    assert sources, "the page names its figures and tables"
    for src in sources:
        assert not re.match(r"[a-z]+:", src), f"external reference {src}"
        assert (report / src).is_file(), src
    assert "<script" not in page.lower() and "@import" not in page and "url(" not in page
    for svg in report.glob("*.svg"):
        assert "http://www.w3.org" in svg.read_text()[:2000]          # namespace only, nothing fetched
        assert not re.search(r'(?:href|src)="https?:', svg.read_text())


@pytest.mark.slow
def test_user_strings_are_escaped(report):
    page = (report / "index.html").read_text()
    assert EVIL not in page and "<img src=x" not in page
    assert "&lt;img src=x onerror=&quot;alert(1)&quot;&gt;&amp;" in page


def expected_extremes(run_dir: Path) -> dict[str, float]:
    """Table 7's extremes recomputed here from the raw rows: feasible accepted designs only."""
    with Store(run_dir / STORE_NAME, readonly=True) as store:
        rows = [r for r in store.evaluations() if r.feasible]
    return {"fy": max(abs(r.figures["fy_span"]) for r in rows), "cl": max(r.figures["c_l"] for r in rows),
            "cmax": min(r.figures["c_max"] for r in rows), "cpmin": min(abs(r.figures["cp_min"]) for r in rows)}


def test_table7_extremes_match_the_store(runs):
    from optimizer.report.analysis import paper_row, points, table7

    run = load_run(runs[0])
    summary = table7(run, points(run))
    for q, v in expected_extremes(runs[0]).items():
        assert summary[q][0] == pytest.approx(v, rel=1e-12)
        assert run.by_key[run.design(summary[q][2]).key].row.feasible
    assert paper_row(run) == (88.16, 4.41, 12.25, 0.50)          # toolpath G1, objectives max |F_Y|, min C_max


@pytest.mark.slow
def test_table7_csv(runs, report):
    expected = expected_extremes(runs[0])
    table = list(csv.DictReader(open(report / "summary.csv")))
    ours = next(t for t in table if t["run"] == "toolpath_g1" and t["source"] == "millfoil")
    for q, v in expected.items():
        assert float(ours[q]) == pytest.approx(v, rel=1e-12)
    paper = next(t for t in table if t["run"] == "toolpath_g1" and t["source"].startswith("Vessaz"))
    assert [float(paper[q]) for q in ("fy", "cl", "cmax", "cpmin")] == [88.16, 4.41, 12.25, 0.50]


@pytest.mark.slow
def test_sections_of_a_running_campaign(runs, report):
    page = (report / "index.html").read_text()
    assert "running" in page and "Not kept" in page
    run = load_run(runs[1])
    assert run.campaign.state == "running"
    designs = list(csv.DictReader(open(report / "designs_1.csv")))
    assert len(designs) == len(run.designs) == 10
    for k in (0, 1):
        assert (report / f"gallery_{k}.svg").stat().st_size > 1000
        gens = list(csv.DictReader(open(report / f"generations_{k}.csv")))
        assert [int(g["generation"]) for g in gens] == list(range(len(gens)))


def test_gallery_designs_lie_on_the_front(runs):
    from optimizer.report.analysis import front, gallery, points

    pts = points(load_run(runs[0]))
    chosen = gallery(pts)
    assert 1 <= len(chosen) <= 6
    on_front = {p.design.number for p in front(pts)}
    assert {p.design.number for p in chosen} <= on_front


def test_fields_of_front_designs_with_files(runs):
    """The fields section draws the front's designs that have a fields file (the synthetic run writes two)
    and lists the front's other designs as not kept; a run without files has nothing to draw."""
    from optimizer.campaign.fields import fields_path
    from optimizer.report.analysis import fields_designs, front, points

    run = load_run(runs[0])
    pts = points(run)
    kept, missing = fields_designs(run, pts)
    on_front = [p.design.key for p in front(pts)]
    assert len(kept) == 2 and all(path.is_file() for _, path in kept)
    assert {p.design.key for p, _ in kept} | {p.design.key for p in missing} == set(on_front)
    assert all(not fields_path(run.directory, p.design.key).exists() for p in missing)
    other = load_run(runs[1])
    kept, missing = fields_designs(other, points(other))
    assert kept == [] and len(missing) == len(front(points(other)))


@pytest.mark.slow
def test_fields_section(report):
    page = (report / "index.html").read_text()
    section = page[page.index('id="fields"'):page.index('id="health"')]
    assert '<img src="fields_0.svg"' in section and (report / "fields_0.svg").stat().st_size > 10_000
    assert "fields_1.svg" not in section and "Not kept for front design(s)" in section


def test_report_input_errors(tmp_path, capsys):
    assert main(["report", str(tmp_path)]) == 2
    assert "no campaign store" in capsys.readouterr().err


def test_a_directory_without_a_store_stands_for_the_runs_below_it(runs, tmp_path):
    from optimizer.report.run import RunError, run_directories

    base = runs[0].parent
    assert run_directories([base]) == sorted(runs)
    study = tmp_path / "study"
    (study / "coarse").mkdir(parents=True)
    shutil.copytree(runs[0], study / "coarse" / runs[0].name)
    assert run_directories([study]) == [study / "coarse" / runs[0].name]     # levels one further down
    assert run_directories([runs[1], base]) == [runs[1], *sorted(runs)]
    with pytest.raises(RunError, match="here or in its subdirectories"):
        run_directories([study / "coarse" / "nothing"])


# ------------------------------------------------------------------------------------------- browser
def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        if shutil.which(name):
            return shutil.which(name)
    return None


#: Injected into a copy of the page (the shipped page has no script): on load, report in the title how many
#: images decoded and any error the page raised.
_PROBE = """<script>
var errors = [];
window.addEventListener('error', function (e) { errors.push(String(e.message || e.target && e.target.src)); }, true);
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  document.title = 'PROBE images ' + ok + '/' + imgs.length + ' errors ' + errors.length + ' ' + errors.join('|');
});
</script>"""


@pytest.mark.slow
def test_page_renders_in_headless_chromium(report, tmp_path):
    """Chromium (Debian package ``chromium``) opens the page from disk with no network: every figure
    decodes, no error event fires, no console error is logged; a screenshot is kept beside the report."""
    browser = _chromium()
    if browser is None:
        pytest.skip("no Chromium found (install it with: apt-get install -y chromium)")
    page = (report / "index.html").read_text()
    probe = report / "probe.html"
    probe.write_text(page.replace("<head>", "<head>" + _PROBE, 1))
    flags = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-extensions",
             f"--user-data-dir={tmp_path / 'profile'}", "--enable-logging=stderr", "--v=0",
             "--virtual-time-budget=10000"]
    dom = subprocess.run([*flags, "--dump-dom", probe.as_uri()], capture_output=True, text=True, timeout=120)
    probe.unlink()
    title = re.search(r"<title>(PROBE[^<]*)</title>", dom.stdout)
    assert title, dom.stderr[-2000:]
    m = re.match(r"PROBE images (\d+)/(\d+) errors (\d+)", title.group(1))
    assert m.group(1) == m.group(2) and int(m.group(2)) >= 5, title.group(1)
    assert m.group(3) == "0", title.group(1)
    console = [x for x in dom.stderr.splitlines() if "CONSOLE" in x]
    assert not console, console
    shot = report / "screenshot.png"
    subprocess.run([*flags, f"--screenshot={shot}", "--window-size=1200,1800", (report / "index.html").as_uri()],
                   capture_output=True, text=True, timeout=120, check=True)
    assert shot.stat().st_size > 10_000
    Path(report / "screenshot.txt").write_text(f"rendered by {browser}\n")


def test_hypervolume_trace_is_the_hypervolume_of_every_point_so_far():
    """Against the hypervolume recomputed from all the points so far, after every point: ties, repeated
    points, points that are dominated or dominate several front points, and points that add nothing."""
    import numpy as np
    from pymoo.indicators.hv import HV

    from optimizer.campaign.store import non_dominated
    from optimizer.report.analysis import hypervolume_trace

    rng = np.random.default_rng(5)
    points = [None if rng.random() < 0.1 else np.round(rng.random(2), 1) for _ in range(300)]
    hv = HV(ref_point=np.array([1.1, 1.1]))
    expected, seen = [], []
    for f in points:
        if f is not None:
            seen.append(f)
        F = np.array(seen).reshape(-1, 2)
        expected.append(float(hv(F[non_dominated(F)])) if len(F) else 0.0)
    assert hypervolume_trace(iter(points), hv).tolist() == expected
    assert hypervolume_trace([None, None], hv).tolist() == [0.0, 0.0]


@pytest.mark.slow
def test_convergence_of_a_surrogate_run_beside_a_plain_one(tmp_path):
    from optimizer.campaign.config import load_campaign
    from optimizer.campaign.driver import run_campaign
    from optimizer.report.analysis import convergence

    path = tmp_path / "zdt1.yaml"
    path.write_text("analytic: {problem: zdt1, variables: 6}\nalgorithm: {population: 12, generations: 4, seed: 3}\n"
                    "execution: {backend: inline}\noutput: {sync: normal}\n")
    run_campaign(load_campaign(path, ["algorithm.method=surrogate", "algorithm.offspring=6",
                                      "algorithm.surrogate={pool: 10, training: 40}"]), tmp_path / "surrogate")
    run_campaign(load_campaign(path, ["algorithm.offspring=6"]), tmp_path / "plain")
    curves = convergence([load_run(tmp_path / "surrogate"), load_run(tmp_path / "plain")])
    for c in curves:
        assert list(c.evaluations) == list(range(1, 31))
        assert all(b >= a for a, b in zip(c.hypervolume, c.hypervolume[1:], strict=False))   # never decreases
        assert c.cpu_hours[-1] > 0
    assert main(["report", str(tmp_path / "surrogate"), str(tmp_path / "plain"), "--out", str(tmp_path / "r")]) == 0
    rows = list(csv.DictReader((tmp_path / "r" / "convergence.csv").open()))
    assert {r["method"] for r in rows} == {"surrogate", "nsga2"} and len(rows) == 60
    assert (tmp_path / "r" / "convergence.svg").is_file()
    assert 'id="convergence"' in (tmp_path / "r" / "index.html").read_text()
    # health: the surrogate's model error per generation, as the store recorded it; none for the plain run
    from optimizer.campaign.store import STORE_NAME, Store

    with Store(tmp_path / "surrogate" / STORE_NAME, readonly=True) as store:
        recorded = {g.generation: g.search or {} for g in store.generations()}
    gens = list(csv.DictReader((tmp_path / "r" / "generations_0.csv").open()))
    assert gens[0]["model_error_f1"] == ""                          # the initial population: no models
    checked = 0
    for row in gens:
        error = recorded[int(row["generation"])].get("error")
        if error:
            checked += 1
            assert float(row["model_error_f2"]) == pytest.approx(error["f2"], rel=1e-12)
            assert float(row["fit_seconds"]) == pytest.approx(recorded[int(row["generation"])]["seconds"]["fit"])
    assert checked >= 3
    assert not any(k.startswith("model_error") for k in next(csv.DictReader((tmp_path / "r" / "generations_1.csv")
                                                                               .open())))
    assert "out-of-sample error on each batch" in (tmp_path / "r" / "index.html").read_text()


def test_runs_sharing_a_directory_name_and_their_siblings_are_named_by_the_tail_that_tells_them_apart(tmp_path):
    from optimizer.report.run import Run, named_apart

    dirs = [tmp_path / "paper" / "coarse" / "design_g1", tmp_path / "paper" / "medium" / "design_g1",
            tmp_path / "paper" / "medium" / "toolpath_g1", tmp_path / "a" / "x" / "run", tmp_path / "b" / "x" / "run",
            tmp_path / "plain"]
    named = named_apart([Run(d, None, {}, ()) for d in dirs])
    assert [r.name for r in named] == ["coarse/design_g1", "medium/design_g1", "medium/toolpath_g1", "a/x/run",
                                       "b/x/run", "plain"]
    assert [r.directory for r in named] == dirs


@pytest.mark.slow
def test_pareto_planes_overlay_two_runs_and_give_more_a_panel_each(runs, tmp_path, monkeypatch):
    import optimizer.report.figures as figures
    from optimizer.report.analysis import points

    drawn = []
    monkeypatch.setattr(figures.plt, "close", drawn.append)     # keep each figure to look at it
    third = synthetic_run(tmp_path / "design_g1", population=4, generations=2, seed=3)
    pairs = [(r, points(r)) for r in (load_run(runs[0]), load_run(runs[1]), load_run(third))]

    figures.pareto_figure(pairs[:2], "cmax", "fy", tmp_path / "two.svg")
    figures.pareto_figure(pairs, "cmax", "fy", tmp_path / "three.svg")
    two, three = drawn
    assert len([ax for ax in two.axes if ax.get_label() != "<colorbar>"]) == 1
    assert {t.get_text().split(":")[0] for t in two.axes[0].get_legend().get_texts()} == {r.name for r, _ in pairs[:2]}
    titles = [ax.get_title() for ax in three.axes if ax.get_title()]
    assert titles == [f"{r.name} ({sum(p.feasible for p in pts)} feasible)" for r, pts in pairs]
    labels = [t.get_text() for t in three.legends[0].get_texts()]
    assert len(labels) == len(set(labels)) and "front" in labels          # one entry per kind of mark
    assert all((tmp_path / name).stat().st_size > 0 for name in ("two.svg", "three.svg"))


def test_a_converged_design_has_no_amplitude_whatever_its_monitor_window_says(runs):
    """A solve the stop test found converged within the monitors' window (200 iterations) has its start-up in
    that window, which may read as an oscillation: its values are steady, and no error bar is drawn."""
    from dataclasses import replace

    from optimizer.report.analysis import points
    from solver.convergence import ConvergenceClass

    run = load_run(runs[0])
    converged = next(d for d in run.designs if d.row.convergence == ConvergenceClass.CONVERGED and d.row.figures)
    oscillating = next(d for d in run.designs if d.row.convergence == ConvergenceClass.OSCILLATING and d.row.figures)
    window = {name: {**m, "status": "oscillating", "amplitude": 40.0} for name, m in converged.row.monitors.items()}
    changed = replace(converged, row=replace(converged.row, monitors=window))
    drawn = {p.design.number: p for p in points(replace(run, designs=(changed, oscillating)))}
    assert drawn[converged.number].dfy == drawn[converged.number].dcmax == 0.0
    assert drawn[oscillating.number].dfy > 0.0 and drawn[oscillating.number].dcmax > 0.0
