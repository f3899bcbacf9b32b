"""The thesis's measurements as data (issue 19, item 1): the file is complete, every
feature it lists is decided by a named decider, the report's numbers come from it,
and a malformed file is refused naming the entry and the field."""

from __future__ import annotations

import re

import pytest

from skidsteer.features import signals
from skidsteer.diagnosis import thesis_features, thesis_targets
from skidsteer.data import thesis_measurements
from skidsteer.reports import reproduction
from skidsteer.data.thesis_measurements import MeasurementsError, load

from test_report import _run, _thesis_like


@pytest.fixture(scope="module")
def measured():
    return load()


def test_every_feature_has_a_source_a_rule_and_a_decider(measured):
    deciders = {f.decider for f in measured.features}
    assert deciders == set(thesis_features.DECIDERS), "deciders without a feature, or the reverse"
    for f in measured.features:
        assert re.search(r"Sec\. \d", f.source), (f.key, f.source)
        for name in f.thresholds:
            assert measured.thresholds[name]["reason"].strip(), name
    # no threshold stands in the file without a feature that reads it
    named = {t for f in measured.features for t in f.thresholds}
    assert named == set(measured.thresholds)


def test_the_22_features_of_the_reproduction_report_are_the_files(measured):
    # the count the README and the mission quote: 22 decided Sec. 3.2 features
    assert len(measured.feature_keys()) == 22
    lift = [{"variant": "ours", "omega_deg_s": w, "wheel_lift_fraction": 0.0}
            for w in thesis_features.LIFT_OMEGAS]
    wheel = {"runs": [dict(_run(w, s, 5.0, 25.0, "high", 0.5, 0.5), mount="wheel")
                      for s in ("concrete", "carpet") for w in range(2, 20, 2)]}
    runs = _thesis_like(rms=0.5)["runs"]
    runs += [dict(r, floor=s) for r in runs for s in ("tile", "carpet")]
    runs += [dict(r, build="platform") for r in runs if r["floor"] != "tile"]
    rows = (thesis_features.sec_3_2_features({"runs": runs}) +
            [thesis_features.lift_feature(lift, "ours")] +
            thesis_features.wheel_mount_features(wheel))
    assert sorted(r["feature"] for r in rows) == sorted(measured.feature_keys())
    for r in rows:
        entry, floor = measured.feature(r["feature"])
        assert r["source"] == entry.source and r["statement"] == entry.statement_for(floor)


def test_the_reports_constants_are_the_files(measured):
    assert thesis_targets.TABLE_5_2["roll"]["peak_hz"] == measured.free_response["roll"]["peak_hz"]
    assert thesis_targets.SPIN_STEADY_N == tuple(measured.pull["spinning_steady_N"]["range"])
    assert thesis_features.VIBRATION_FLOOR_M_S2 == measured.threshold("vibration_floor_m_s2")
    assert thesis_features.LIFT_OMEGAS == tuple(measured.threshold("lift_omegas_deg_s"))
    # the analysis computes its band features with its own band edges: the same numbers
    assert signals.LOW_BAND_HZ[1] == measured.threshold("low_hz")
    assert signals.HIGH_BAND_HZ[0] == measured.threshold("high_hz")


def test_a_threshold_moved_in_the_file_moves_the_verdict(tmp_path, monkeypatch):
    # the deciders read the file's thresholds, not copies: a stricter "usually"
    # (0.95) fails the two-peak feature on runs that pass it at 0.5
    analysis = _thesis_like(rms=0.5)
    key = "low_and_high_below_30_concrete"
    before = {r["feature"]: r["reproduced"] for r in
              thesis_features.sec_3_2_features(analysis, ("concrete",))}
    analysis["runs"][0]["top_peaks_hz"]["y"] = [8.0, 6.0, 15.0]  # one run not low+high
    text = thesis_measurements.default_path().read_text()
    strict = text.replace('[thresholds.usually_fraction]\nvalue = 0.5',
                          '[thresholds.usually_fraction]\nvalue = 0.95')
    assert strict != text
    path = tmp_path / "strict.toml"
    path.write_text(strict)
    monkeypatch.setattr(thesis_features, "MEASURED", load(path))
    after = {r["feature"]: r["reproduced"] for r in
             thesis_features.sec_3_2_features(analysis, ("concrete",))}
    assert before[key] is True and after[key] is False


@pytest.mark.parametrize("edit, named", [
    (('source = "Table 5.2 (peak frequency, mean and std of 8 trials); Sec. 5.2 (decay rate)"\n',
      '', 1), "free_response.roll.source"),
    (("peak_hz = 6.0425", "peak_hz = -6.0", 1), "free_response.roll.peak_hz"),
    (("concrete = [180.0, 200.0]", "concrete = [200.0, 180.0]", 1),
     "pull.lateral_first_peak_N.concrete"),
    (('reason = "a rank or linear correlation over fewer than 5 points is not a trend"',
      'reason = " "', 1), "thresholds.min_trend_runs.reason"),
    (('decider = "high_rises"\n', '', 1), "(high_rises_{floor}).decider"),
    (('thresholds = ["linear_correlation"]', 'thresholds = ["linearity"]', 1),
     "(carpet_amplitude_linear).thresholds"),
    (('floors = ["concrete", "tile"]', 'floors = ["concrete", "gravel"]', 1),
     "(dominance_switch_{floor}).floors"),
    (('omegas = "above_split"', 'omegas = "fast"', 1), "(both_low_above_30_{floor}).omegas"),
    (("max_omega_deg_s = 40", "max_omega_deg_s = -40", 1), "calibration.max_omega_deg_s"),
    (('floors = ["concrete", "carpet"]\nmax_omega', 'floors = ["parquet"]\nmax_omega', 1),
     "calibration.floors"),
])
def test_a_malformed_file_names_its_entry_and_field(tmp_path, edit, named):
    old, new, count = edit
    text = thesis_measurements.default_path().read_text()
    assert old in text, old
    path = tmp_path / "measurements.toml"
    path.write_text(text.replace(old, new, count))
    with pytest.raises(MeasurementsError) as err:
        load(path)
    assert "measurements.toml" in str(err.value) and named in str(err.value), str(err.value)


def test_the_fitted_set_is_what_item_3_allows_a_calibration_on(measured, tmp_path):
    # issue 19, item 3: fit only on the extended build, cube on the platform, on concrete
    # and carpet at omega <= 40 deg/s; a feature whose rule reads any other run (the
    # platform, tile, omega > 40, the lift-off onset, the cube on a wheel) is predicted
    fitted = sorted(k for k in measured.feature_keys() if measured.fitted(k))
    assert fitted == ["high_rises_carpet", "high_rises_concrete",
                      "low_and_high_below_30_carpet", "low_and_high_below_30_concrete"]
    # the split follows the file: widen the calibration to tile and the tile twins join
    text = thesis_measurements.default_path().read_text()
    wider = text.replace('floors = ["concrete", "carpet"]\nmax_omega',
                         'floors = ["concrete", "tile", "carpet"]\nmax_omega', 1)
    assert wider != text
    assert set(k for k in measured.feature_keys() if _loaded(wider, tmp_path / "wider.toml").fitted(k)) == \
        set(fitted) | {"high_rises_tile", "low_and_high_below_30_tile"}
    # a calibration below the split (30 deg/s) holds no feature: every rule reads runs up
    # to it
    lower = text.replace("max_omega_deg_s = 40", "max_omega_deg_s = 20", 1)
    assert not any(_loaded(lower, tmp_path / "lower.toml").fitted(k) for k in measured.feature_keys())


def _loaded(text: str, path):
    path.write_text(text)
    return load(path)


def test_the_report_lists_the_rules_and_what_no_rule_decides(measured):
    md = reproduction._decision_rules()
    for f in measured.features:
        assert f.rule in md
    for u in measured.undecided:
        assert u["statement"] in md
