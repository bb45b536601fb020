"""The report page: one static HTML file, its SVG figures and CSV tables beside it.

The page needs no network (no script, no CDN, no web font: inline CSS, figures as relative ``<img>``), and
every string that comes from a store or a configuration is escaped (:func:`html.escape`).

:func:`write_report` first computes the page and names every file it will write, checks each of their
paths (:func:`optimizer.saving.check_output_directory`: a path that is a directory is refused, exit status
2, before anything is drawn), then writes them all under temporary names and renames them onto their names
together (:func:`optimizer.saving.write_all`): a failure part-way — a full disk, a figure that cannot be
drawn — leaves no file and the previous report as it was (WriteFailure, exit status 4).
"""

from __future__ import annotations

import csv
import datetime as _dt
import html
import os
import platform
import statistics
import sys
import zipfile
from collections.abc import Callable
from functools import partial
from importlib import metadata
from pathlib import Path

from optimizer.campaign.fields import read_fields
from optimizer.report.analysis import (
    TABLE7_COLUMNS,
    Health,
    convergence,
    fields_designs,
    gallery,
    health,
    paper_row,
    points,
    table7,
)
from optimizer.report.figures import (
    convergence_figure,
    fields_figure,
    gallery_figure,
    health_figure,
    pareto_figure,
    study_fronts_figure,
    study_pairs_figure,
)
from optimizer.report.run import Run, named_apart
from optimizer.report.study import (
    C2_LIFT_DROP,
    LIFT_DIFFERENCE,
    G1Pairs,
    case_name,
    claims,
    fronts_by_case,
    g1_pairs,
    is_study,
    kept_fields,
    mesh_dependence,
    steadiness,
    study_levels,
    study_order,
    table7_rows,
)
from optimizer.saving import check_output_directory, write_all

#: The files of a report, by name: each writes its file at the path it is given (a temporary name).
Files = dict[str, Callable[[Path], object]]

#: Packages whose versions the provenance section lists.
PACKAGES = ("millfoil", "numpy", "scipy", "shapely", "pymoo", "gmsh", "matplotlib", "dask", "distributed", "ezdxf")

_CSS = """
body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;color:#222;line-height:1.4}
h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;margin-top:1.6em}h3{font-size:1em}
table{border-collapse:collapse;margin:.5em 0;font-size:.85em}td,th{border:1px solid #ccc;padding:2px 6px;
text-align:right}th{background:#f0f0f0}td.l,th.l{text-align:left}img{max-width:100%;height:auto}
.note{color:#555;font-size:.85em}pre{background:#f6f6f6;padding:.5em;overflow:auto;font-size:.8em;max-height:30em}
.paper{color:#555;font-style:italic}nav a{margin-right:1em}
"""


def e(value) -> str:
    """An escaped string of any value (quotes too: safe in attributes)."""
    return html.escape(str(value), quote=True)


def write_report(runs: list[Run], out: Path, option: str = "--out") -> Path:
    """Write ``out/index.html`` with its figures and tables for ``runs``, all or none of them (see the module
    docstring; ``option`` names ``out`` in an OutputError); returns the page's path."""
    out = Path(out)
    runs = named_apart(runs)
    files: Files = {}
    pts = [points(r) for r in runs]
    pairs = list(zip(runs, pts, strict=True))
    study = is_study(runs)
    drawn = [pairs[i] for i in study_order(runs)] if study else pairs     # a study's panels in Table 7's order
    files["pareto_fy_cmax.svg"] = partial(pareto_figure, drawn, "cmax", "fy")
    files["pareto_cl_cpmin.svg"] = partial(pareto_figure, drawn, "cpmin", "cl")
    sections = [_fronts(runs, pts), _summary(runs, pts), _study(runs, pts, files) if study else "",
                _gallery(runs, pts, files), _fields(runs, pts, files), _convergence(runs, files), _health(runs, files),
                _provenance(runs)]
    _tables(runs, pts, files)
    title = "millfoil report: " + ", ".join(r.name for r in runs)
    now = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
    states = "; ".join(f"{r.name}: {r.campaign.state}, {len(r.designs)} designs, {len(r.generations)} generations"
                       for r in runs)
    nav = [("fronts", "Pareto fronts"), ("summary", "Summary"), *([("study", "Paper study")] if study else []),
           ("gallery", "Geometry"), ("fields", "Fields"), ("convergence", "Convergence"), ("health", "Health"),
           ("provenance", "Provenance")]
    page = (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{e(title)}</title>"
            f"<style>{_CSS}</style></head><body>\n<h1>{e(title)}</h1>\n"
            f"<p class=\"note\">Generated {e(now)} from the stores (read-only; a running campaign shows what has "
            f"finished). {e(states)}.</p>\n<nav>" + "".join(f"<a href=\"#{a}\">{t}</a>" for a, t in nav)
            + "</nav>\n" + "\n".join(x for x in sections if x) + "\n</body></html>\n")
    files["index.html"] = lambda path: path.write_text(page, encoding="utf-8")     # renamed last
    check_output_directory(out, option, files=list(files))
    # the figures are drawn on every core this process may use: a study's dozens of figures take a minute on one
    write_all([(out / name, write) for name, write in files.items()], jobs=len(os.sched_getaffinity(0))
              if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1)
    return out / "index.html"


def fields_shown(runs: list[Run]) -> dict[Path, set[str]]:
    """``{run directory: keys}`` of the designs whose fields files (``RUN/fields/<key>.npz``) the report of
    ``runs`` draws: the Flow fields section's and, for a paper study, the G1 pairs'. A copy of the runs that
    keeps only these files draws the same page (``bench/paper_study.py --archive``)."""
    pts = [points(r) for r in runs]
    shown = {r.directory: {p.design.key for p, _ in fields_designs(r, p)[0]} for r, p in zip(runs, pts, strict=True)}
    if is_study(runs):
        for g in (g for lv in study_levels(runs, pts) if (g := g1_pairs(lv)) is not None):
            for pair in g.pairs:
                for run, p in ((g.design, pair.design), (g.toolpath, pair.toolpath)):
                    if p is not None and kept_fields(run, p) is not None:
                        shown[run.directory].add(p.design.key)
    return shown


def _img(src: str, alt: str) -> str:
    return f'<p><img src="{e(src)}" alt="{e(alt)}"></p>'


def _fronts(runs: list[Run], pts) -> str:
    missing = []
    for r, p in zip(runs, pts, strict=True):
        solved = {x.design.number for x in p}
        counts: dict[str, int] = {}
        for d in r.designs:
            if d.number not in solved:
                counts[d.row.status] = counts.get(d.row.status, 0) + 1
        if counts:
            missing.append(f"{r.name}: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())))
    note = ("Designs without values (not drawn): " + "; ".join(missing) + ".") if missing else ""
    return ("<h2 id=\"fronts\">Pareto fronts</h2>\n<p class=\"note\">Every solved design, shaded by the generation "
            "that first asked for it; feasible accepted designs filled, others marked by status; an oscillating "
            "value is its window mean with its amplitude as an error bar (Vessaz et al. 2013, Fig. 9–11). "
            f"{e(note)} Every design: <a href=\"designs_0.csv\">designs_0.csv</a> (one file per run, in the order "
            "given).</p>\n" + _img("pareto_fy_cmax.svg", "|F_Y| against C_max")
            + _img("pareto_cl_cpmin.svg", "C_L against |C_p,min|"))


def _summary(runs: list[Run], pts) -> str:
    head = "".join(f"<th>{e(label)}</th>" for label, _, _ in TABLE7_COLUMNS)
    rows = []
    for r, p in zip(runs, pts, strict=True):
        t = table7(r, p)
        cells = "".join("<td>-</td>" if t[q] is None else
                        f"<td>{t[q][0]:.2f} <span class=\"note\">({e(t[q][1])}, #{t[q][2]})</span></td>"
                        for _, q, _ in TABLE7_COLUMNS)
        rows.append(f"<tr><td class=\"l\">{e(r.name)} <span class=\"note\">({e(r.mode)} {e(r.continuity)})</span>"
                    f"</td>{cells}</tr>")
        paper = paper_row(r)
        if paper:
            rows.append("<tr class=\"paper\"><td class=\"l\">paper, Table 7: " + e(f"{r.continuity} "
                        f"{'Tool path' if r.mode == 'toolpath' else 'Design'}") + "</td>"
                        + "".join(f"<td>{v:.2f}</td>" for v in paper) + "</tr>")
    return ("<h2 id=\"summary\">Summary (Table 7)</h2>\n<p class=\"note\">Extremes over the feasible accepted "
            "designs, with the convergence class and number of the design that reaches each. For the paper's "
            "cases (same blade family, objectives max |F_Y|, min C_max) the paper's Table 7 row is shown below ours "
            "(Vessaz et al. 2013; its channel and mesh differ: docs/explanation/campaigns.md). Table: "
            "<a href=\"summary.csv\">summary.csv</a>.</p>\n"
            f"<table><tr><th class=\"l\">run</th>{head}</tr>{''.join(rows)}</table>")


def _study(runs: list[Run], pts, files: Files) -> str:
    """The "Paper study" section (:mod:`optimizer.report.study`): Table 7 side by side, Fig. 9, the G1 pairs
    of Fig. 10–13 at each mesh level that has both G1 runs, the claims table, and the fronts of each case run
    at two mesh levels read side by side (only where there is one); runs in Table 7's order (:func:`study_order`,
    which keeps the runs of one case and level in the order given)."""
    order = study_order(runs)
    runs, pts = [runs[i] for i in order], [pts[i] for i in order]
    parts = ["<h2 id=\"study\">Paper study</h2>\n<p class=\"note\">The runs of the paper's cases (blade family "
             "and objectives max |F_Y|, min C_max) beside Vessaz et al. (2013), compared within one mesh level. "
             "The paper's channel and mesh differ from ours (docs/explanation/campaigns.md): compare magnitudes "
             "and orderings, not digits. Verdict rules: docs/explanation/reports.md.</p>",
             _study_table7(runs, pts, files)]
    files["study_fronts.svg"] = partial(study_fronts_figure, fronts_by_case(runs, pts))
    parts.append("<h3>Fronts of the cases (Fig. 9)</h3>" + _img("study_fronts.svg", "C_L against |C_p,min|, "
                 "the front of each case"))
    levels = study_levels(runs, pts)
    ignored = [name for lv in levels for name in lv.ignored]
    if ignored:
        parts.append(f"<p class=\"note\">Not used in the comparisons (a run of the same case and mesh level "
                     f"comes first): {e(', '.join(ignored))}.</p>")
    parts.append("<h3>Designs along the G1 fronts (Fig. 10–13)</h3>")
    found = [g for lv in levels if (g := g1_pairs(lv)) is not None]
    if not found:
        parts.append("<p class=\"note\">Needs the G1 design and G1 tool-path runs at one mesh level.</p>")
    for k, g in enumerate(found):
        parts.append(_study_pairs(g, k, files))
    parts.append(_study_claims(runs, pts, files))
    parts.append(_study_mesh(runs, pts, files))
    return "\n".join(parts)


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:+.1f} %"


def _study_table7(runs: list[Run], pts, files: Files) -> str:
    rows = table7_rows(runs, pts)
    head = "".join(f"<th>{e(label)}</th><th class=\"paper\">paper</th><th>Δ</th>" for label, _, _ in TABLE7_COLUMNS)
    body = []
    for t in rows:
        cells = "".join(
            ("<td>-</td>" if t.ours[q] is None else f"<td>{t.ours[q][0]:.2f} <span class=\"note\">(#{t.ours[q][2]})"
             "</span></td>") + f"<td class=\"paper\">{t.paper_value(q):.2f}</td><td>{_pct(t.relative(q))}</td>"
            for _, q, _ in TABLE7_COLUMNS)
        body.append(f"<tr><td class=\"l\">{e(t.run.name)}</td><td class=\"l\">{e(case_name(t.case))}</td>"
                    f"<td class=\"l\">{e(t.level)}</td><td>{t.evaluations}{_unfinished(t.run)}</td>{cells}</tr>")
    files["table7.csv"] = partial(_study_table7_csv, rows)
    return ("<h3>Table 7 side by side</h3>\n<p class=\"note\">Ours (extremes over the feasible accepted designs, "
            "design number in brackets), the paper's Table 7 value beside it and Δ = (ours − paper) / paper; the "
            "mesh level and the CFD evaluations each run spent (the paper: about 5 000 per case, medium mesh), with "
            "the state of a run that has not finished. Table: <a href=\"table7.csv\">table7.csv</a>.</p>\n"
            "<table><tr><th class=\"l\">run</th>"
            f"<th class=\"l\">case</th><th class=\"l\">mesh</th><th>CFD evaluations</th>{head}</tr>"
            f"{''.join(body)}</table>")


def _unfinished(run: Run) -> str:
    state = run.campaign.state
    return "" if state == "finished" else f" <span class=\"note\">({e(state)})</span>"


def _study_table7_csv(rows, path: Path) -> None:
    cols = [q for _, q, _ in TABLE7_COLUMNS]
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["run", "mode", "continuity", "mesh_level", "cfd_evaluations",
                    *[f"{q}{suffix}" for q in cols for suffix in ("", "_paper", "_relative", "_design", "_class")]])
        for t in rows:
            values = []
            for q in cols:
                ours, rel = t.ours[q], t.relative(q)
                values += [repr(ours[0]) if ours else "", t.paper_value(q), repr(rel) if rel is not None else "",
                           ours[2] if ours else "", ours[1] if ours else ""]
            w.writerow([t.run.name, t.case[0], t.case[1], t.level, t.evaluations, *values])


def _walls(g: G1Pairs) -> tuple[dict[str, dict | None], list[str]]:
    """The fields arrays of the paired designs that have a readable file, and the unreadable ones."""
    walls, unreadable = {}, []
    for pair in g.pairs:
        for run, p in ((g.design, pair.design), (g.toolpath, pair.toolpath)):
            path = kept_fields(run, p) if p is not None else None
            if path is None:
                continue
            try:
                walls[p.design.key] = read_fields(path)
            except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:      # being replaced, or damaged
                unreadable.append(f"{run.name} #{p.design.number} ({type(exc).__name__})")
    return walls, unreadable


def _study_pairs(g: G1Pairs, k: int, files: Files) -> str:
    walls, unreadable = _walls(g)
    files[f"g1_pairs_{k}.svg"] = partial(study_pairs_figure, g, walls)
    files[f"g1_pairs_{k}.csv"] = partial(_pairs_csv, g)

    def side(p) -> str:
        if p is None:
            return "<td>-</td>" * 4
        return (f"<td>#{p.design.number}</td><td>{p.cl:.3f}</td><td>{p.cpmin:.3f}</td>"
                f"<td class=\"l\">{e(steadiness(p, 'fy'))}{'' if p.design.key in walls else ', fields not kept'}</td>")

    rows = "".join(f"<tr><td>{x.index}</td>{side(x.design)}{side(x.toolpath)}"
                   f"<td>{'-' if x.distance is None else f'{x.distance:.3f}'}</td></tr>" for x in g.pairs)
    note = f" Unreadable fields file(s): {e(', '.join(unreadable))}." if unreadable else ""
    return (f"<h4>{e(g.level)} mesh: {e(g.design.name)} and {e(g.toolpath.name)}</h4>\n<p class=\"note\">Six "
            "designs spread evenly (by arc length) along the G1 design front in (C_L, |C_p,min|) normalised over "
            "both fronts, each paired with the nearest unused design of the G1 tool-path front, nearest pairs "
            "first (the paper's points are \"as near as possible for both cases\"); blades rebuilt from their "
            "stored parameters, C_p along the wall where the run kept the design's fields file." + note
            + f" Table: <a href=\"g1_pairs_{k}.csv\">g1_pairs_{k}.csv</a>.</p>\n"
            + _img(f"g1_pairs_{k}.svg", "G1 design and tool-path designs paired along their fronts")
            + "<table><tr><th>pair</th><th>design</th><th>C_L</th><th>|C_p,min|</th><th class=\"l\">class</th>"
            "<th>tool path</th><th>C_L</th><th>|C_p,min|</th><th class=\"l\">class</th><th>distance</th></tr>"
            f"{rows}</table>")


def _pairs_csv(g: G1Pairs, path: Path) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["pair", "distance", *[f"{s}_{c}" for s in ("design", "toolpath")
                                          for c in ("run", "number", "key", "c_l", "cp_min_abs", "fy_span_N",
                                                    "c_max", "class")]])
        for x in g.pairs:
            cells = []
            for run, p in ((g.design, x.design), (g.toolpath, x.toolpath)):
                cells += ([run.name, p.design.number, p.design.key, repr(p.cl), repr(p.cpmin), repr(p.fy),
                           repr(p.cmax), steadiness(p, "fy")] if p is not None else [run.name, *[""] * 7])
            w.writerow([x.index, "" if x.distance is None else repr(x.distance), *cells])


def _study_claims(runs: list[Run], pts, files: Files) -> str:
    found = claims(runs, pts)
    files["claims.csv"] = partial(_claims_csv, found)
    rows = "".join(
        f"<tr><td class=\"l\">({e(c.key)}) {e(c.statement)}</td><td class=\"l\">{e(c.level)}</td>"
        f"<td class=\"l\">{e(c.ours)}</td><td class=\"l paper\">{e(c.paper)}</td><td class=\"l\"><b>{e(c.verdict)}"
        f"</b></td><td class=\"l\">{'<br>'.join(e(u.describe()) for u in c.used) or '-'}</td></tr>" for c in found)
    low, high = C2_LIFT_DROP
    return ("<h3>The paper's conclusions</h3>\n<p class=\"note\">Each statement of the paper's §4 tested on our runs "
            f"of one mesh level. (a) holds when every continuity class with both approaches differs by less than "
            f"{100 * LIFT_DIFFERENCE:.0f} % in max |F_Y|; (b) when min C_max of the tool path exceeds the design's in "
            f"every such class; (c) when the C2 lift drop lies within {100 * low:.0f}–{100 * high:.0f} % for both "
            "approaches. A test that changes its answer within the oscillation amplitudes of the designs compared "
            "cannot tell; so does a claim without the runs it needs. Only finished runs are tested: a run still "
            "going, or stopped before its end, is in Table 7 with its state. The paper's column applies the same "
            "test to its own Table 7. Table: <a href=\"claims.csv\">claims.csv</a>.</p>\n"
            "<table><tr><th class=\"l\">claim</th>"
            "<th class=\"l\">mesh</th><th class=\"l\">ours</th><th class=\"l paper\">paper, Table 7</th>"
            f"<th class=\"l\">verdict</th><th class=\"l\">designs used</th></tr>{rows}</table>")


def _study_mesh(runs: list[Run], pts, files: Files) -> str:
    found = mesh_dependence(runs, pts)
    if not found:
        return ""
    files["mesh_dependence.csv"] = partial(_mesh_csv, found)

    def side(p) -> str:
        return "<td>-</td>" if p is None else (f"<td>{p.fy:.1f} <span class=\"note\">(#{p.design.number}, "
                                               f"{e(steadiness(p, 'fy'))})</span></td>")

    rows = "".join(f"<tr><td class=\"l\">{e(case_name(m.case))}</td><td class=\"l\">{e(' / '.join(m.levels))}</td>"
                   f"<td>{b:.2f}</td>{side(a)}{side(f)}<td>{_gap(m.gap(i))}</td>"
                   f"<td>{_pct(m.difference(i))}</td></tr>"
                   for m in found for i, (b, (a, f)) in enumerate(zip(m.bounds, m.best, strict=True)))
    return ("<h3>Mesh dependence</h3>\n<p class=\"note\">Each case run to its end at two mesh levels: the two "
            "|F_Y|–C_max fronts read at common C_max bounds, from the higher of the two lowest C_max to the lower "
            "of their C_max at maximum lift. At each bound, the largest |F_Y| (N over the span) of the designs "
            "with C_max at most the bound, their difference (finer − coarser) and its share of the coarser. The "
            "runs are separate searches as well as separate meshes, so Δ holds both. Table: "
            "<a href=\"mesh_dependence.csv\">mesh_dependence.csv</a>.</p>\n<table><tr><th class=\"l\">case</th>"
            "<th class=\"l\">meshes</th><th>C_max ≤ [m/s]</th><th>|F_Y| [N], coarser</th><th>|F_Y| [N], finer</th>"
            "<th>Δ [N]</th><th>Δ</th></tr>"
            f"{rows}</table>")


def _gap(value: float | None) -> str:
    return "-" if value is None else f"{value:+.1f}"


def _mesh_csv(found, path: Path) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["mode", "continuity", "coarser_level", "finer_level", "c_max_bound",
                    *[f"{side}_{c}" for side in ("coarser", "finer")
                      for c in ("run", "number", "fy_span_N", "c_max", "class")], "gap_N", "relative"])
        for m in found:
            for i, (b, pair) in enumerate(zip(m.bounds, m.best, strict=True)):
                cells = []
                for run, p in zip(m.runs, pair, strict=True):
                    cells += ([run.name, p.design.number, repr(p.fy), repr(p.cmax), steadiness(p, "fy")]
                              if p is not None else [run.name, "", "", "", ""])
                gap, d = m.gap(i), m.difference(i)
                w.writerow([*m.case, *m.levels, repr(b), *cells, "" if gap is None else repr(gap),
                            "" if d is None else repr(d)])


def _claims_csv(found, path: Path) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["claim", "mesh_level", "verdict", "ours", "paper", "designs"])
        for c in found:
            w.writerow([c.key, c.level, str(c.verdict), c.ours, c.paper, " | ".join(u.describe() for u in c.used)])


def _gallery(runs: list[Run], pts, files: Files) -> str:
    parts = ["<h2 id=\"gallery\">Geometry along the front</h2>\n<p class=\"note\">About six designs spread "
             "along each run's |F_Y|–C_max front (Fig. 12–13), rebuilt from their stored parameters. Numbers are "
             "design numbers (<code>millfoil export RUN --id N</code>).</p>"]
    for k, (r, p) in enumerate(zip(runs, pts, strict=True)):
        chosen = gallery(p)
        parts.append(f"<h3>{e(r.name)}</h3>")
        if not chosen:
            parts.append("<p>No feasible design yet.</p>")
            continue
        files[f"gallery_{k}.svg"] = partial(gallery_figure, r, chosen)
        parts.append(_img(f"gallery_{k}.svg", f"blades of {r.name}"))
    return "\n".join(parts)


def _fields(runs: list[Run], pts, files: Files) -> str:
    parts = ["<h2 id=\"fields\">Flow fields of selected designs</h2>\n<p class=\"note\">Up to three designs of "
             "each run's |F_Y|–C_max front (its ends and middle) whose fields the campaign kept (<code>RUN/fields/"
             "</code>: the wall distribution and |U| sampled around the blade, written by the worker and kept "
             "for the front's designs only): velocity magnitude near the blade, C_p (axis reversed) and c_f "
             "along the suction and pressure sides, y+ of the wall cells. The report does not solve designs "
             "again: a design without a file is listed as not kept (re-run it with <code>millfoil evaluate</code>)."
             "</p>"]
    for k, (r, p) in enumerate(zip(runs, pts, strict=True)):
        parts.append(f"<h3>{e(r.name)}</h3>")
        kept, missing = fields_designs(r, p)
        chosen, unreadable = [], []
        for point, path in kept:
            try:
                chosen.append((point, read_fields(path)))
            except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:      # a file being replaced, or damaged
                unreadable.append(f"#{point.design.number} ({type(exc).__name__})")
        if chosen:
            files[f"fields_{k}.svg"] = partial(fields_figure, chosen)
            parts.append(_img(f"fields_{k}.svg", f"fields of designs of {r.name}"))
        notes = []
        if missing:
            notes.append("Not kept for front design(s) " + ", ".join(f"#{x.design.number}" for x in missing)
                         + " (no fields file: written before the campaign kept fields, or not written by the worker"
                         " — its reason says why).")
        if unreadable:
            notes.append("Unreadable fields file(s): " + ", ".join(unreadable) + ".")
        if not chosen and not missing:
            notes.append("Not kept: no design of this run has a fields file yet.")
        if notes:
            parts.append(f"<p class=\"note\">{e(' '.join(notes))}</p>")
    return "\n".join(parts)


def _convergence(runs: list[Run], files: Files) -> str:
    """Hypervolume against the CFD spent, every run on one scale (a plain run given beside a surrogate run
    draws the comparison)."""
    same = len({tuple(r.labels) for r in runs}) == 1
    if not same:
        return ("<h2 id=\"convergence\">Convergence</h2>\n<p class=\"note\">The runs optimise different objectives: "
                "their hypervolumes are not comparable and are not drawn together.</p>")
    curves = convergence(runs)
    files["convergence.svg"] = partial(convergence_figure, curves)

    def write_csv(path: Path) -> None:
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["run", "method", "evaluations", "cpu_hours", "hypervolume"])
            for c in curves:
                method = c.run.config.get("algorithm", {}).get("method", "nsga2")
                for n, h, v in zip(c.evaluations, c.cpu_hours, c.hypervolume, strict=True):
                    w.writerow([c.run.name, method, int(n), repr(float(h)), repr(float(v))])

    files["convergence.csv"] = write_csv
    rows = "".join(
        f"<tr><td class=\"l\">{e(c.run.name)}</td><td class=\"l\">"
        f"{e(c.run.config.get('algorithm', {}).get('method', 'nsga2'))}</td><td>{len(c.evaluations)}</td>"
        f"<td>{c.cpu_hours[-1] if len(c.cpu_hours) else 0:.2f}</td>"
        f"<td>{c.hypervolume[-1] if len(c.hypervolume) else 0:.4f}</td></tr>" for c in curves)
    return ("<h2 id=\"convergence\">Convergence</h2>\n<p class=\"note\">Hypervolume of every feasible design stored "
            "so far against the CFD evaluations spent (failed ones included; geometrically infeasible designs never "
            "reach the CFD) and against their CPU hours. One scale for all runs shown: each minimised objective "
            "mapped so that its best and worst feasible values over these runs are 0 and 1, reference point 1.1. "
            "Give a plain NSGA-II run beside a surrogate-assisted one to compare them. Table: "
            "<a href=\"convergence.csv\">convergence.csv</a>.</p>\n" + _img("convergence.svg", "hypervolume against "
            "CFD evaluations") + "<table><tr><th class=\"l\">run</th><th class=\"l\">method</th><th>CFD evaluations"
            f"</th><th>CPU hours</th><th>hypervolume</th></tr>{rows}</table>")


def _health(runs: list[Run], files: Files) -> str:
    parts = ["<h2 id=\"health\">Campaign health</h2>"]
    for k, r in enumerate(runs):
        h = health(r)
        files[f"health_{k}.svg"] = partial(health_figure, h)
        files[f"generations_{k}.csv"] = partial(_generations_csv, h)
        total = sum(h.cache_hits)
        parts.append(f"<h3>{e(r.name)}</h3><p class=\"note\">{len(r.designs)} designs stored, {total} cache hits; "
                     f"{_model_error_note(h)}per generation: <a href=\"generations_{k}.csv\">generations_{k}.csv"
                     "</a>.</p>" + _img(f"health_{k}.svg", f"health of {r.name}"))
    return "\n".join(parts)


def _model_error_note(h) -> str:
    """The surrogate's out-of-sample error over the run, in words (empty for a plain run)."""
    medians = {k: [v for v in values if v is not None] for k, values in h.model_error.items()}
    medians = {k: statistics.median(v) for k, v in medians.items() if v}
    if not medians:
        return ""
    text = ", ".join(f"{e(k)} {v:.0%}" for k, v in medians.items())
    return (f"the models' out-of-sample error on each batch, median over the generations: {text} (RMSE in standard "
            "deviations of the training values; 100 % is what predicting their mean gives); ")


def _provenance(runs: list[Run]) -> str:
    versions = []
    for name in PACKAGES:
        try:
            versions.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            continue
    machine = f"{platform.node()} ({platform.platform()}, {os.cpu_count()} CPUs), Python {sys.version.split()[0]}"
    parts = ["<h2 id=\"provenance\">Provenance</h2>",
             f"<p>Report made with {e(', '.join(versions))} on {e(machine)}.</p>"]
    for r in runs:
        c = r.campaign
        workers = sorted({d.row.worker for d in r.designs if d.row.worker})
        parts.append(
            f"<h3>{e(r.name)}</h3><table>"
            + "".join(f"<tr><th class=\"l\">{e(k)}</th><td class=\"l\">{e(v)}</td></tr>" for k, v in (
                ("run directory", r.directory.resolve()), ("state", c.state), ("message", c.message or "-"),
                ("started", c.started), ("ended", c.ended or "-"), ("millfoil version of the run", c.version),
                ("seed", c.seed), ("workers", ", ".join(workers[:8]) + (" …" if len(workers) > 8 else "") or "-")))
            + f"</table><details><summary>resolved configuration</summary><pre>{e(c.config)}</pre></details>")
    return "\n".join(parts)


def _tables(runs: list[Run], pts, files: Files) -> None:
    files["summary.csv"] = partial(_summary_csv, runs, pts)
    for k, (r, p) in enumerate(zip(runs, pts, strict=True)):
        files[f"designs_{k}.csv"] = partial(_designs_csv, r, p)


def _summary_csv(runs: list[Run], pts, path: Path) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["run", "mode", "continuity", "source", *[q for _, q, _ in TABLE7_COLUMNS],
                    *[f"{q}_class" for _, q, _ in TABLE7_COLUMNS], *[f"{q}_design" for _, q, _ in TABLE7_COLUMNS]])
        for r, p in zip(runs, pts, strict=True):
            t = table7(r, p)
            cols = [q for _, q, _ in TABLE7_COLUMNS]
            w.writerow([r.name, r.mode, r.continuity, "millfoil",
                        *[repr(t[q][0]) if t[q] else "" for q in cols], *[t[q][1] if t[q] else "" for q in cols],
                        *[t[q][2] if t[q] else "" for q in cols]])
            paper = paper_row(r)
            if paper:
                w.writerow([r.name, r.mode, r.continuity, "Vessaz et al. 2013 Table 7", *paper, *[""] * 8])


def _designs_csv(r: Run, p, path: Path) -> None:
    values = {x.design.number: x for x in p}
    names = sorted({n for d in r.designs for n in d.row.parameters})
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["design", "key", "generation", "status", "class", "feasible", "fy_span_N", "c_l", "c_max",
                    "cp_min_abs", "fy_amplitude_N", "c_max_amplitude", "wall_seconds", "reason", *names])
        for d in r.designs:
            v = values.get(d.number)
            nums = [v.fy, v.cl, v.cmax, v.cpmin, v.dfy, v.dcmax] if v else [""] * 6
            w.writerow([d.number, d.key, d.row.generation, d.row.status, d.row.convergence or "",
                        d.row.feasible, *nums, d.row.wall_seconds or "", d.row.reason,
                        *[d.row.parameters.get(n, "") for n in names]])


def _generations_csv(h: Health, path: Path) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        # statuses and convergence classes share names (oscillating, not_converged): prefixed, so that no two
        # columns have the same header
        w.writerow(["generation", "hypervolume", "feasible_share", "cache_hits", *[f"status_{k}" for k in h.by_status],
                    *[f"class_{k}" for k in h.by_class],
                    *[f"model_error_{k}" for k in h.model_error], *[f"failed_{k}" for k in h.failures],
                    *[f"{k}_seconds" for k in h.seconds]])
        for i, g in enumerate(h.generations):
            w.writerow([g, _blank(h.hypervolume[i]), _blank(h.feasible_share[i]), h.cache_hits[i],
                        *[v[i] for v in h.by_status.values()], *[v[i] for v in h.by_class.values()],
                        *[_blank(v[i]) for v in (*h.model_error.values(), *h.failures.values(), *h.seconds.values())]])


def _blank(value):
    return "" if value is None else value
