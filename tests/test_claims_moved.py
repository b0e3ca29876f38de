"""tools/studies/claims_moved.py: the verdicts that differ between two results pages, cell by cell."""

import json

from tools.studies import claims_moved


def _results(path, cells):
    claims = [
        {"id": "fixed_gait_p_cost", "claim": "less energy", "measure": "Ours / trot", "cells": cells},
    ]
    path.write_text(json.dumps({"claims": claims}))
    return str(path)


def _cell(label, est, ci, verdict):
    return {"label": label, "kind": "ratio", "estimate": est, "ci95": ci, "n": 3, "verdict": verdict}


def test_only_the_cells_whose_verdict_changed_are_listed(tmp_path, capsys):
    before = _results(
        tmp_path / "b.json",
        [_cell("v_x task", 0.3, [0.2, 0.4], "holds"), _cell("three moving tasks", 0.8, [0.46, 1.4], "undecided")],
    )
    after = _results(
        tmp_path / "a.json",
        [
            _cell("v_x task", 0.31, [0.21, 0.47], "holds"),
            _cell("three moving tasks", 0.73, [0.58, 0.91], "holds"),
            _cell("w task", 0.84, [0.5, 1.4], "undecided"),
        ],
    )
    out = tmp_path / "moved.json"
    assert claims_moved.main(["--before", before, "--after", after, "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["moved"] == ["fixed_gait_p_cost | three moving tasks"]  # v_x holds in both
    assert r["compared"] == 2 and r["only_after"] == ["fixed_gait_p_cost | w task"]  # new data, not a move
    assert "1 of 2 comparisons with data in both changed" in capsys.readouterr().out
    (tmp_path / "empty.json").write_text("{}")
    assert claims_moved.main(["--before", str(tmp_path / "empty.json"), "--after", after]) == 2
