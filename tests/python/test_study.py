"""caustica.study.realtime and `caustica study realtime`: a tiny run writes the report, the table and the
plots; the spp needed grows as the threshold falls; bad input is one line and exit status 2."""
import json
import os
import warnings

import pytest

import caustica
from caustica import cli
from caustica import study as S


def test_spp_needed_interpolates_and_marks():
    levels = [1, 2, 4, 8]
    flips = [0.4, 0.2, 0.1, 0.05]           # slope -1 in log-log
    assert S.spp_needed(levels, flips, 0.5) == (1.0, "<=")
    n, how = S.spp_needed(levels, flips, 0.1)
    assert how == "interpolated" and n == pytest.approx(4.0)
    n, how = S.spp_needed(levels, flips, 0.141421356)
    assert how == "interpolated" and n == pytest.approx(2.0 ** 1.5, rel=1e-6)
    n, how = S.spp_needed(levels, flips, 0.025)
    assert how == "extrapolated" and n == pytest.approx(16.0, rel=1e-6)
    assert S.spp_needed(levels, [0.3, 0.3, 0.3, 0.3], 0.1) == (None, "not reached")
    assert S.spp_levels(10) == [1, 2, 4, 8, 10]


def test_realtime_study_tiny(tmp_path, capsys):
    out = tmp_path / "rt"
    thresholds = ["0.3", "0.15", "0.08"]
    rc = cli.main(["study", "realtime", "cornell", "--integrators", "path", "sppm", "--size", "24x24",
                   "--max-spp", "8", "--seeds", "2", "--ref-spp", "128", "--thresholds", *thresholds,
                   "--out", str(out), "--quiet"])
    assert rc == 0
    printed = capsys.readouterr().out
    assert "| integrator | mean FLIP ≤ | spp needed |" in printed
    report = (out / "report.md").read_text()
    assert "| integrator | mean FLIP ≤ | spp needed | throughput (samples/s) |" in report
    assert "**Device:** Renders on the CPU" in report and "`--device cuda` runs this study there" in report
    assert "scaled to 1920x1080" in report
    for f in ("flip_vs_spp.png", "flip_vs_spp.svg", "flip_vs_frame_time.png", "results.json"):
        assert (out / f).stat().st_size > 0, f
    assert (out / "flip_vs_spp.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    refs = list((out / "reference").glob("*.exr"))
    assert len(refs) == 1 and refs[0].with_suffix(".json").exists()
    res = json.loads((out / "results.json").read_text())
    rows = res["table"]
    assert len(rows) == 2 * len(thresholds)
    for integ in ("path", "sppm"):
        mine = sorted((r for r in rows if r["integrator"] == integ), key=lambda r: -r["threshold"])
        needed = [r["spp_needed"] for r in mine]
        assert all(n is not None for n in needed), mine
        assert needed == sorted(needed) and needed[0] < needed[-1], mine        # lower threshold: more spp
        for r in mine:
            assert r["frame_ms"] == pytest.approx(1000 * r["spp_needed"] * 1920 * 1080 / r["samples_per_s"])
            assert r["speedup_missing"] == pytest.approx(r["frame_ms"] / (1000 / 60))
        flips = [c["flip"] for c in res["curves"][integ]]
        assert flips[-1] < flips[0]

    # The Python function: same table shape; the cached reference is reused (its sidecar's date is kept).
    meta = json.loads(refs[0].with_suffix(".json").read_text())
    r2 = caustica.study.realtime("cornell", integrators=["path"], size=(24, 24), max_spp=2, seeds=1, ref_spp=128,
                                 thresholds=[0.3], out=out)
    assert [set(r) >= {"integrator", "threshold", "spp_needed", "frame_ms", "speedup_missing"} for r in r2["table"]]
    assert r2["reference"]["date"] == meta["date"]
    # An integrator variant (adaptive photon tracing) is studied under its own name.
    r3 = caustica.study.realtime("cornell", integrators=["sppm+adaptive"], size=(24, 24), max_spp=2, seeds=1,
                                 ref_spp=128, thresholds=[0.3], out=out)
    assert {r["integrator"] for r in r3["table"]} == {"sppm+adaptive"}
    assert [c["spp"] for c in r3["curves"]["sppm+adaptive"]] == [1, 2]


def test_realtime_throughput_measured_at_1080p(tmp_path):
    """throughput_at="1080p" measures samples/s with renders at the scene's aspect at 1920x1080's pixel count
    (the GPU's default; here on the CPU) and the frame times follow from that figure."""
    res = caustica.study.realtime("cornell", integrators=["path"], size=(24, 24), max_spp=2, seeds=1, ref_spp=64,
                                  thresholds=[0.3], throughput_at="1080p", throughput_spp=1, out=tmp_path / "rt")
    st = res["settings"]
    assert st["throughput_at"] == "1080p" and st["throughput_size"] == [1440, 1440]   # square: 1440^2 = 1920*1080
    rates = res["throughput_renders"]["path"]
    assert len(rates) == 2 and res["throughput"]["path"] == max(rates)                 # max(2, seeds) renders
    row = res["table"][0]
    assert row["samples_per_s"] == res["throughput"]["path"]
    assert row["frame_ms"] == pytest.approx(1000 * row["spp_needed"] * 1920 * 1080 / row["samples_per_s"])
    report = (tmp_path / "rt" / "report.md").read_text()
    assert "measured at 1440x1440" in report and "samples/s at 1440x1440" in report


def test_throughput_size_keeps_the_scenes_aspect(tmp_path):
    """The 1080p throughput renders take the scene's aspect, not that of the curves' `size`: a 2:1 scene studied
    at 24x24 measures at 2036x1018 (1018^2 * 2 ~ 1920*1080)."""
    f = tmp_path / "wide.json"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        caustica.export_scene("cornell", str(f))
    d = json.loads(f.read_text())
    d["camera"]["width"], d["camera"]["height"] = 64, 32
    f.write_text(json.dumps(d))
    res = caustica.study.realtime(str(f), integrators=["path"], size=(24, 24), max_spp=1, seeds=1, ref_spp=16,
                                  thresholds=[0.3], throughput_at="1080p", throughput_spp=1)
    assert res["settings"]["size"] == [24, 24] and res["settings"]["throughput_size"] == [2036, 1018]


def test_cuda_integrators_are_the_wavefront_ones():
    """_api.CUDA_INTEGRATORS (what `study --device cuda` offers) is exactly the set the native options check
    lets run on the wavefront drivers, which are the drivers --device cuda runs."""
    tiny = caustica.load_scene("cornell", width=8, height=8)
    for name in caustica.integrators():
        try:
            caustica.render_job(tiny, integrator=name, spp=1, wavefront=True)
            runs = True
        except caustica.InputError as e:
            assert "--wavefront runs" in str(e), e
            runs = False
        assert runs == (name in caustica._api.CUDA_INTEGRATORS), name


def test_study_device_errors():
    """A bad device or throughput size is one line; without a GPU, --device cuda is one line saying so."""
    with pytest.raises(caustica.InputError, match="unknown device 'tpu'"):
        caustica.study.realtime("cornell", device="tpu")
    with pytest.raises(caustica.InputError, match="throughput_at: expected 'small' or '1080p'"):
        caustica.study.realtime("cornell", throughput_at="4k")
    if not caustica._api.cuda_status()[0]:  # every variant runs on the GPU: past the checks above
        with pytest.raises(caustica.InputError, match="device 'cuda' is not available"):
            caustica.study.realtime("cornell", integrators=["path", "restir+nohistory", "sppm+adaptive"],
                                    device="cuda")


@pytest.mark.skipif(not caustica._api.cuda_status()[0], reason="needs a CUDA device (none here: the CPU study "
                    "runs in test_realtime_study_tiny)")
def test_realtime_study_on_gpu(tmp_path):
    """On a GPU: the study renders there and measures throughput at 1080p by default."""
    res = caustica.study.realtime("cornell", integrators=["path", "sppm"], size=(24, 24), max_spp=4, seeds=1,
                                  ref_spp=256, thresholds=[0.3], device="cuda", out=tmp_path / "rt")
    assert res["settings"]["throughput_at"] == "1080p" and res["gpu"]
    assert res["reference"]["device"] == "cuda"
    assert "Renders on cuda" in (tmp_path / "rt" / "report.md").read_text()


@pytest.mark.parametrize("argv", [
    ["study", "realtime", "cornell", "--throughput-at", "4k"],
    ["study", "realtime", "no-such-scene"],
    ["study", "realtime", "cornell", "--integrators", "bogus"],
    ["study", "realtime", "cornell", "--thresholds", "1.5"],
    ["study", "realtime", "cornell", "--size", "10"],
    ["study", "realtime", "cornell", "--max-spp", "0"],
    ["study"],
])
def test_study_bad_input_exits_2(argv, capsys, tmp_path):
    assert cli.main(argv + ["--out", str(tmp_path / "x")] if len(argv) > 1 else argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("caustica: error:"), err
    assert not (tmp_path / "x").exists()


def test_study_python_bad_input():
    with pytest.raises(caustica.InputError):
        caustica.study.realtime("cornell", thresholds=[0])
    with pytest.raises(caustica.InputError):
        caustica.study.realtime("cornell", integrators=["nope"])
    with pytest.raises(caustica.InputError):
        caustica.study.realtime("cornell", max_spp=0)
