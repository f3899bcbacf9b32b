"""The committed malformed-dataset corpus (tests/malformed/, issue 7).

tests/malformed/dataset is one dataset: three good runs and every kind of bad
input (see tests/malformed/make_corpus.py).  expected.json gives, for each bad
file, the fragments its message must contain (file and place, per
docs/data-format.md).  The good runs must load; every bad one must
be skipped with its message; nothing else may be skipped, and no other
exception than the reader's DataError may escape.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from skidsteer.cli import main
from skidsteer.data import read_dataset

CORPUS = Path(__file__).resolve().parent / "malformed"
EXPECTED = json.loads((CORPUS / "expected.json").read_text())


@pytest.fixture(scope="module")
def dataset():
    return read_dataset(CORPUS / "dataset")


def test_the_good_runs_of_the_corpus_load(dataset):
    assert [info.file for info, _ in dataset.runs] == EXPECTED["good"]
    assert all(rec.accel.shape == (2100, 3) for _, rec in dataset.runs)


def test_every_bad_file_is_skipped_and_nothing_else(dataset):
    assert sorted(s["file"] for s in dataset.skipped) == sorted(EXPECTED["skipped"])


@pytest.mark.parametrize("file", sorted(EXPECTED["skipped"]))
def test_each_bad_file_gets_its_message(dataset, file):
    [reason] = [s["reason"] for s in dataset.skipped if s["file"] == file]
    for fragment in EXPECTED["skipped"][file]:
        assert fragment in reason, (file, reason)


def test_analyze_lists_the_skipped_files_and_analyses_the_rest(tmp_path, capsys):
    assert main(["analyze", str(CORPUS / "dataset"), "--out", str(tmp_path), "--no-figures",
                 "--json"]) == 0
    capsys.readouterr()
    result = json.loads((tmp_path / "analysis.json").read_text())
    assert sorted(r["file"] for r in result["runs"]) == sorted(EXPECTED["good"])
    assert sorted(s["file"] for s in result["skipped"]) == sorted(EXPECTED["skipped"])
