"""The numbers the docs quote come from benchmarks/numbers.json, written by the benchmark scripts
(``--record``): every generated block of the files of ``render_docs.FILES`` (README.md,
benchmarks/README.md, docs/validation.md, docs/dma.md, fitting/README.md) equals what
benchmarks/render_docs.py writes from that file, so a re-measured number cannot leave a stale
copy in the docs, and a hand edit of a generated number fails here."""

import importlib.util
import json
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _render_docs():
    spec = importlib.util.spec_from_file_location("render_docs", REPO / "benchmarks" / "render_docs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_generated_blocks_match_numbers_file():
    rd = _render_docs()
    numbers = json.loads(rd.NUMBERS.read_text())
    seen = set()
    for path in rd.FILES:
        text = path.read_text()
        seen.update(rd.blocks(text))
        assert rd.render(text, numbers) == text, f"{path.name}: stale; run python benchmarks/render_docs.py"
    assert seen == set(rd.BLOCKS), f"blocks not placed in any file: {set(rd.BLOCKS) - seen}"


def test_numbers_file_records_where_it_was_measured():
    numbers = json.loads((REPO / "benchmarks" / "numbers.json").read_text())
    for name, section in numbers.items():
        m = section["measured"]
        assert m["cores"] >= 1 and m["cpu"] and m["date"] and len(m["load_average"]) == 3, name


def test_methods_table_flags_what_the_method_flagged():
    # the rendering must not drop a flag: a row whose points were all invalid says "(flagged)"
    rd = _render_docs()
    rows = [dict(geometry="sphere", H=0.005, V=v, method=m, valid=(m == "full"), deviation=d)
            for v, d in ((1e-3, 0.0), (1e-2, -0.25)) for m in ("full", "direct")]
    assert rd._deviations(rows, "sphere", 0.005, "direct") == "0, -25 % (flagged)"
    rows[3]["valid"] = True
    assert rd._deviations(rows, "sphere", 0.005, "direct") == "0, -25 % (1 of 2 flagged)"
    assert rd._deviations(rows, "sphere", 0.005, "full") == "reference"


def test_recorded_default_grid_errors_are_bounded_by_their_truncation():
    # docs/validation.md's default-grid table says "the truncation bounds the error at N of N
    # points": a re-analysis (resistance_forms.py --analyse --record) that breaks the promise fails here
    rows = json.loads((REPO / "benchmarks" / "numbers.json").read_text())["resistance_forms"]["rows"]
    defaults = [r["default"] for r in rows if r["default"] is not None]
    assert len(defaults) >= 60  # 2 geometries x the calibration and validation points of the study
    assert all(abs(d["error"]) <= d["truncation"] for d in defaults)


def test_recorded_edge_smoothing_bias_within_the_envelope_the_truncation_uses():
    # docs/validation.md's edge-smoothing table (edge_smoothing_bias.py --record) against the
    # envelopes of jaxroll.grids that the truncation doubles: a re-measured bias above them fails
    # here, and so does a record whose grids the rule no longer gives (re-run the script)
    from jaxroll import grids

    runs = json.loads((REPO / "benchmarks" / "numbers.json").read_text())["edge_smoothing"]["runs"]
    assert {"sphere-f1", "cylinder-f1"} <= set(runs) and len(runs) >= 5
    for key, run in runs.items():
        model = "sphere3d" if key.startswith("sphere") else "cylinder"
        k = run["kappa"]
        rule = grids.sphere_cells_per_radius if model == "sphere3d" else grids.cylinder_cells_per_radius
        for r in run["rows"]:
            if key.split("-", 1)[1].startswith("f"):  # a standard linear solid (breadth 0): on today's rule
                assert round(r["cells"]) == rule(r["zeta"]), (key, r["zeta"], r["cells"])
            assert abs(r["extrapolated"]) <= 100 * grids.EDGE_EXTRAPOLATED_BIAS[model], (key, r)
            assert abs(r["kappa"]) <= 100 * grids.EDGE_BIAS_SCALE[model] * k**1.5, (key, r)
            assert abs(r["kappa2"]) <= 100 * grids.EDGE_BIAS_SCALE[model] * (2 * k) ** 1.5, (key, r)


def test_recorded_fit_examples_are_the_guides_commands():
    # fitting/README.md's table (fit_examples.py --record) describes the guide's own commands: an
    # edit of an example that is not re-measured fails here
    import re

    spec = importlib.util.spec_from_file_location("fit_examples", REPO / "benchmarks" / "fit_examples.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    text = (REPO / "fitting" / "README.md").read_text()
    guide = [" ".join(line.split()) for block in re.findall(r"```bash\n(.*?)```", text, re.S)
             for line in re.sub(r"\\\n\s*", " ", block).splitlines() if line.startswith("jaxroll fit")]
    assert [command for _, command, _ in module.EXAMPLES] == guide
    rows = json.loads((REPO / "benchmarks" / "numbers.json").read_text())["fit_examples"]["rows"]
    assert {name: row["command"] for name, row in rows.items()} == {name: c for name, c, _ in module.EXAMPLES}


def test_recorded_thin_layer_tables_are_the_librarys():
    # docs/validation.md's thin-layer table (thin_layer_error.py --analyse --record): the tables
    # jaxroll.grids reads are the recorded envelope (a re-analysis that moves them, or a hand edit
    # of either, fails here), and the truncation bounds every recorded default point
    import numpy as np

    from jaxroll import grids

    sec = json.loads((REPO / "benchmarks" / "numbers.json").read_text())["thin_layer_error"]
    for g in ("cylinder", "sphere"):
        assert np.array_equal(np.asarray(sec["tables"][g]["thin_error"]), np.asarray(grids.THIN_ERROR[g])), g
    assert np.array_equal(np.asarray(sec["tables"]["cylinder"]["thin_broad_error"]),
                          np.asarray(grids.THIN_BROAD_ERROR["cylinder"]))
    assert sum(r["points"] for r in sec["summary"]) >= 600
    assert all(r["bounded"] == r["points"] for r in sec["summary"])
