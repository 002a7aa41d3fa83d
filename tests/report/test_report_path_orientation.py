"""The report's path section with a 6-DoF probe's orientation figures (AT_a..RT_c, deg)."""

import json

from calibrator.report import path_section as ps
from calibrator.report import verify_section as vs

ANGLES = {"ATa_deg": 0.1232, "ATb_deg": 0.0182, "ATc_deg": 0.133,
          "RTa_deg": 0.108, "RTb_deg": 0.0312, "RTc_deg": 0.1246}  # fmt: skip


def path_doc(compensated, angles):
    """A verify --path line result; ``angles``: its orientation figures, or None (reflector)."""
    s = [float(k) for k in range(0, 100, 10)]
    path = {
        "shape": "line", "speed_mm_s": 400.0, "speed_pct": 100.0, "cycles": 2,
        "compensated": compensated, "AT_P_mm": 0.99, "RT_P_mm": 0.02, "AV_pct": 0.05,
        "RV_pct": 0.003, "FV_mm_s": 4.5,
        "points": {"s_mm": s, "AT_mm": [0.99] * len(s), "RT_mm": [0.02] * len(s)},
    }  # fmt: skip
    path |= {k: (None if angles is None else angles[k]) for k in ANGLES}
    return {"format": "calibrator.verify", "test": "path", "path": path}


def _table(tmp_path, docs):
    files = []
    for name, doc in docs:
        (tmp_path / name).write_text(json.dumps(doc))
        files.append(tmp_path / name)
    html, _ = vs.add("<html><body></body></html>", vs.load(files))
    return html[html.index("<table>") : html.index("</table>")]


def test_a_six_dof_run_adds_its_orientation_columns_and_a_reflectors_run_leaves_them_blank(
    tmp_path,
):
    table = _table(
        tmp_path, [("six.json", path_doc(False, ANGLES)), ("three.json", path_doc(True, None))]
    )
    head, six, three = table.split("<tr>")[1:]
    names = [name for _, name in ps.ORIENTATION]
    assert names == ["AT_a deg", "AT_b deg", "AT_c deg", "RT_a deg", "RT_b deg", "RT_c deg"]
    assert "".join(f"<th>{n}</th>" for n in names) in head
    assert "".join(f"<td>{ANGLES[k]:.4f}</td>" for k, _ in ps.ORIENTATION) in six
    assert three.rstrip().endswith("<td></td>" * 6 + "</tr>")


def test_reflector_runs_alone_get_no_orientation_columns(tmp_path):
    table = _table(tmp_path, [("a.json", path_doc(False, None))])
    assert "deg" not in table
