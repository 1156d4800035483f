"""Bench reading that cannot silently go wrong: the same TE written the ways benches and published
data sets write it gives the same features, and every sampling the order analysis cannot use is
refused with one message naming the file.

The datasets here are written as text directly (not through :func:`write_bench`), so the reader is
tested against files it did not produce.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from rvflex import catalog
from rvflex.diagnosis.bench import BenchError, read_bench
from rvflex.diagnosis.features import measured_runs
from rvflex.diagnosis.plan import plan_from_dataset
from rvflex.diagnosis.settings import DiagnosisSettings

SPEC = catalog.load("rv40e")
RATIO = SPEC.nominal_ratio
ARCSEC = math.pi / 648000.0
K = 127
# a TE with the orders an RV-40E shows (1, z_c, z_b, 2·z_b, 3·z_b) plus a wind-up, in arcsec
HARMONICS = {1: (3.0, -1.5), 39: (0.8, 0.4), 40: (2.5, -1.0), 80: (1.2, 0.9), 120: (0.4, -0.3)}
MEAN = -220.0
NOISE = 0.1  # arcsec rms, as the self-check's output encoder


def _te(p: np.ndarray) -> np.ndarray:
    out = np.full_like(p, MEAN)
    for k, (a, b) in HARMONICS.items():
        out += a * np.cos(k * p) + b * np.sin(k * p)
    return out


def _positions(n_per_rev: int, revs: float, *, inclusive: bool, jitter: float = 0.0, seed: int = 0) -> np.ndarray:
    """Output positions (rad) from 0.3 rad on: N per revolution over [0, 2π·revs) or inclusively."""
    n = int(round(n_per_rev * revs)) + (1 if inclusive else 0)
    j = np.arange(n, dtype=float)
    if jitter:
        j[1:-1] += np.random.default_rng(seed).uniform(-jitter, jitter, n - 2)
    return 0.3 + 2 * np.pi * j / n_per_rev


def _write(folder: Path, files: dict[str, str], runs: list[str]) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (folder / name).write_text(text)
    (folder / "bench.toml").write_text('[reducer]\ncatalog = "rv40e"\n\n' + "\n".join(runs))
    return folder


def _encoder_csv(p: np.ndarray, direction: int = 1, seed: int = 1) -> str:
    rng = np.random.default_rng(seed)
    pos = p if direction > 0 else p[0] - (p - p[0])  # reverse: the output turns backwards
    te = (_te(pos) + rng.normal(0, NOISE, len(pos))) * ARCSEC
    th_in = RATIO * pos
    th_out = pos + te + 0.01  # an encoder offset
    q = 2 * np.pi / 2**23
    th_out = np.round(th_out / q) * q
    t = np.arange(len(pos)) * 4.0 / len(pos)
    rows = "\n".join(f"{a:.17g},{b:.17g},{c:.17g}" for a, b, c in zip(t, th_in, th_out))
    return "time_s,theta_in_rad,theta_out_rad\n" + rows + "\n"


def _run(file: str, direction: str = "forward") -> str:
    return f'[[run]]\nfile = "{file}"\nkind = "te"\ndirection = "{direction}"\nload_Nm = 412.0\nspeed_out_rpm = 15.0\n'


def _features(folder: Path) -> tuple[list[np.ndarray], dict]:
    ds = read_bench(folder)
    s = DiagnosisSettings(max_order=K, positions_per_rev=256)
    f, lay, info = measured_runs(ds, plan_from_dataset(ds, s), s)
    out = []
    for r in lay.te_runs:
        out.append(np.r_[f[lay.dc[r]], f[lay.cos[r]], f[lay.sin[r]]])
    return out, info


def _truth(offset_arcsec: float = 0.01 / ARCSEC) -> np.ndarray:
    a, b = np.zeros(K), np.zeros(K)
    for k, (ak, bk) in HARMONICS.items():
        a[k - 1], b[k - 1] = ak, bk
    return np.r_[MEAN + offset_arcsec, a, b]


# coefficient noise: σ·√(2/n) ≈ 0.004″ at 1024 samples; 0.03″ is 7σ and a tenth of an arcsecond's noise
TOL_ARCSEC = 0.03


@pytest.mark.parametrize("label, n, revs, inclusive, jitter", [
    ("[0, 2π), one revolution", 1024, 1, False, 0.0),
    ("inclusive [0, 2π], one revolution", 1024, 1, True, 0.0),
    ("[0, 2π), three revolutions", 1024, 3, False, 0.0),
    ("inclusive, three revolutions", 1024, 3, True, 0.0),
    ("partial last revolution", 1024, 1.6, False, 0.0),
    ("non-uniform positions", 1024, 1, False, 0.3),
])
def test_encoder_sampling_conventions_give_the_same_features(tmp_path, label, n, revs, inclusive, jitter):
    p = _positions(n, revs, inclusive=inclusive, jitter=jitter)
    folder = _write(tmp_path / "b", {"te.csv": _encoder_csv(p)}, [_run("te.csv")])
    (f,), info = _features(folder)
    np.testing.assert_allclose(f, _truth(), atol=TOL_ARCSEC, err_msg=label)
    w = info[0]
    assert w["revolutions"] == int(revs) and w["coverage"] >= 0.999
    # the analysed window is whole revolutions: an inclusive endpoint and a partial revolution stay out
    assert w["samples"] == n * int(revs)


def test_reverse_run_reads_the_same_te(tmp_path):
    p = _positions(1024, 1, inclusive=False)
    folder = _write(tmp_path / "b", {"rev.csv": _encoder_csv(p, direction=-1)}, [_run("rev.csv", "reverse")])
    (f,), _ = _features(folder)
    np.testing.assert_allclose(f, _truth(), atol=TOL_ARCSEC)


def _angle_csv(p: np.ndarray, unit: str, both: bool = False, seed: int = 2) -> str:
    rng = np.random.default_rng(seed)
    scale = 1.0 if unit == "arcsec" else 1 / 3600
    deg = np.degrees(p)
    if both:
        fw = (_te(p) + rng.normal(0, NOISE, len(p))) * scale
        rv = (_te(p) + 5.0 + rng.normal(0, NOISE, len(p))) * scale  # reverse: 5″ more wind-up
        rows = "\n".join(f"{a:.12g},{b:.12g},{c:.12g}" for a, b, c in zip(deg, fw, rv))
        return f"output_angle_deg,te_forward_{unit},te_reverse_{unit}\n" + rows + "\n"
    te = (_te(p) + rng.normal(0, NOISE, len(p))) * scale
    return f"output_angle_deg,te_{unit}\n" + "\n".join(f"{a:.12g},{b:.12g}" for a, b in zip(deg, te)) + "\n"


@pytest.mark.parametrize("unit", ["arcsec", "deg"])
@pytest.mark.parametrize("revs, inclusive", [(1, False), (1, True), (3, False)])
def test_angle_and_te_form_gives_the_encoder_features(tmp_path, unit, revs, inclusive):
    p = _positions(1024, revs, inclusive=inclusive)
    enc = _write(tmp_path / "enc", {"te.csv": _encoder_csv(p)}, [_run("te.csv")])
    ang = _write(tmp_path / "ang", {"te.csv": _angle_csv(p, unit)}, [_run("te.csv")])
    (fe,), _ = _features(enc)
    (fa,), info = _features(ang)
    assert info[0]["form"] == "angle"
    # the angle form has no encoder offset: compare the orders, and the mean less the offset
    np.testing.assert_allclose(fa[1:], fe[1:], atol=2 * TOL_ARCSEC)
    assert abs(fa[0] - (fe[0] - 0.01 / ARCSEC)) < 2 * TOL_ARCSEC


def test_both_directions_in_one_angle_file(tmp_path):
    p = _positions(720, 1, inclusive=True)
    folder = _write(tmp_path / "b", {"te.csv": _angle_csv(p, "arcsec", both=True)}, [_run("te.csv", "both")])
    ds = read_bench(folder)
    assert [r.direction for r in ds.runs] == ["forward", "reverse"]
    s = DiagnosisSettings(max_order=K, positions_per_rev=256)
    plan = plan_from_dataset(ds, s)
    assert [p.direction for p in plan] == [1, -1]
    (fw, rv), _ = _features(folder)
    np.testing.assert_allclose(rv[1:], fw[1:], atol=3 * TOL_ARCSEC)
    assert abs(rv[0] - fw[0] - 5.0) < 3 * TOL_ARCSEC


# ----------------------------------------------------------------------------- refused


def _refused(folder: Path, where: str, problem: str) -> None:
    with pytest.raises(BenchError) as info:
        ds = read_bench(folder)
        s = DiagnosisSettings(max_order=K, positions_per_rev=256)
        measured_runs(ds, plan_from_dataset(ds, s), s)
    assert where in info.value.where, info.value
    assert problem in info.value.problem, info.value


def test_short_coverage_is_refused(tmp_path):
    p = _positions(1024, 0.97, inclusive=False)
    folder = _write(tmp_path / "b", {"te.csv": _encoder_csv(p)}, [_run("te.csv")])
    _refused(folder, "te.csv", "cover 0.970 of an output revolution")


def test_a_gap_inside_the_revolution_is_refused(tmp_path):
    p = _positions(1024, 1, inclusive=False)
    p = np.r_[p[:300], p[330:]]  # 30 samples (2.9 % of the turn) lost
    folder = _write(tmp_path / "b", {"te.csv": _encoder_csv(p)}, [_run("te.csv")])
    _refused(folder, "te.csv", "cover 0.97")


def test_too_few_samples_per_order_is_refused(tmp_path):
    p = _positions(360, 1, inclusive=False)  # 1° steps: 2.8 samples per order up to 127
    folder = _write(tmp_path / "b", {"te.csv": _angle_csv(p, "arcsec")}, [_run("te.csv")])
    _refused(folder, "te.csv", "at least 4 samples per fitted order (508)")


def test_duplicated_angle_with_different_te_is_refused(tmp_path):
    p = _positions(1024, 1, inclusive=False)
    rows = _angle_csv(p, "arcsec").splitlines()
    cells = rows[100].split(",")
    rows.insert(101, f"{cells[0]},{float(cells[1]) + 3.0}")
    folder = _write(tmp_path / "b", {"te.csv": "\n".join(rows) + "\n"}, [_run("te.csv")])
    _refused(folder, "te.csv, rows 101 and 102", "appears twice with different TE")


def test_arcseconds_written_as_degrees_are_refused(tmp_path):
    p = _positions(1024, 1, inclusive=False)
    rows = _angle_csv(p, "arcsec").splitlines()
    rows[0] = "output_angle_deg,te_deg"  # the values are arcseconds
    folder = _write(tmp_path / "b", {"te.csv": "\n".join(rows) + "\n"}, [_run("te.csv")])
    _refused(folder, "te.csv, column 'te_deg'", "arcseconds written as degrees")


def test_wrapped_angles_are_refused_with_the_fix(tmp_path):
    p = np.mod(_positions(1024, 2, inclusive=False), 2 * np.pi)
    folder = _write(tmp_path / "b", {"te.csv": _angle_csv(p, "arcsec")}, [_run("te.csv")])
    _refused(folder, "column 'output_angle_deg'", "unwrapped")


def test_the_issue_case_one_revolution_at_n_samples_is_not_misread(tmp_path):
    """The misreading of issue 12: N samples over (N − 1)/N of a revolution kept one sample and
    reported a 114 311″ TE for an 8.5″ unit. Now the whole revolution is analysed."""
    p = _positions(4096, 1, inclusive=False)
    folder = _write(tmp_path / "b", {"te.csv": _encoder_csv(p)}, [_run("te.csv")])
    (f,), info = _features(folder)
    assert info[0]["samples"] == 4096
    assert abs(info[0]["te_pp_fit_arcsec"] - info[0]["te_pp_measured_arcsec"]) < 1.0
    np.testing.assert_allclose(f, _truth(), atol=TOL_ARCSEC)


def test_writer_round_trips_the_angle_form_with_both_directions(tmp_path):
    """write_bench writes a forward and a reverse angle-form run on the same angles into one file
    (``direction = "both"``) and read_bench gives them back."""
    from rvflex.diagnosis.bench import BenchDataset, BenchRun, write_bench

    p = 2 * np.pi * np.arange(720) / 720
    runs = tuple(BenchRun("te.csv", "te", np.empty(0), np.empty(0), np.empty(0), np.empty(0), direction=d,
                          load_Nm=412.0, speed_out_rpm=15.0, form="angle", position_rad=p,
                          te_rad=1e-5 * np.sin(3 * p) + (1e-6 if d == "reverse" else 0.0))
                 for d in ("forward", "reverse"))
    write_bench(tmp_path, BenchDataset(SPEC, "rv40e", runs))
    assert 'direction = "both"' in (tmp_path / "bench.toml").read_text()
    ds = read_bench(tmp_path)
    assert [r.direction for r in ds.runs] == ["forward", "reverse"]
    for got, want in zip(ds.runs, runs):
        np.testing.assert_allclose(got.te_rad, want.te_rad, atol=1e-12)  # 12 significant digits of arcsec
        assert got.window.samples == 720 and got.window.coverage == pytest.approx(1.0)
