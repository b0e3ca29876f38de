"""The committed results page and the README's status table are functions of the committed results.json: a page or
table edited by hand, or left behind by new results, fails here."""

import os

from wqwarp.cli import readme_status
from wqwarp.eval.report import regenerate_page

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_the_committed_results_page_regenerates_from_its_json_byte_for_byte():
    committed, regenerated = regenerate_page(os.path.join(ROOT, "docs"), "cpu")
    assert regenerated == committed


def test_the_readme_status_table_is_the_one_the_committed_results_build(capsys):
    assert readme_status.main(["--check"]) == 0, capsys.readouterr().out
