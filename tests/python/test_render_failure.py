"""A render that fails midway (out of memory, a device error) keeps what it had: Python raises RenderError with
the image of the passes completed before the failure, and `caustica render` writes that image, says so in one
line and exits with status 1. The failure is injected with the test hook CAUSTICA_TEST_FAIL_AT_PASS (pass N
fails as soon as it starts; integrator/render.cpp)."""
import numpy as np
import pytest

import caustica
from caustica import cli

CASES = {
    "path": dict(integrator="path"),
    "path-wavefront": dict(integrator="path", wavefront=True),
    "sppm": dict(integrator="sppm"),
    "pppm-wavefront": dict(integrator="pppm", wavefront=True),
    "ppm-wavefront": dict(integrator="ppm", wavefront=True),
    "vcm": dict(integrator="vcm"),
    "restir": dict(integrator="restir"),
}


@pytest.fixture(scope="module")
def scene():
    return caustica.load_scene("cornell", width=24, height=24)


@pytest.mark.parametrize("case", list(CASES))
def test_partial_image_is_that_of_the_complete_passes(scene, case, monkeypatch):
    kw = CASES[case]
    expected = caustica.render_job(scene, spp=3, seed=2, **kw)
    monkeypatch.setenv("CAUSTICA_TEST_FAIL_AT_PASS", "3")
    with pytest.raises(caustica.RenderError) as e:
        caustica.render_job(scene, spp=8, seed=2, **kw)
    assert "pass 3 failed" in str(e.value)
    partial = e.value.partial
    assert partial is not None and partial.interrupted and partial.stats["passes"] == 3
    assert partial.stats["integrator"] == kw["integrator"]
    assert np.array_equal(partial.image, expected.image)  # the passes are deterministic: bit for bit


def test_failure_in_the_first_pass_has_no_image(scene, monkeypatch):
    monkeypatch.setenv("CAUSTICA_TEST_FAIL_AT_PASS", "0")
    with pytest.raises(caustica.RenderError) as e:
        caustica.render(scene, spp=4)
    assert e.value.partial is None
    assert isinstance(e.value, RuntimeError)  # callers catching RuntimeError still do


def test_cli_writes_what_it_had(tmp_path, monkeypatch, capsys):
    out = tmp_path / "partial.exr"
    expected = caustica.render(caustica.load_scene("cornell", width=24, height=24), spp=2, seed=0)
    monkeypatch.setenv("CAUSTICA_TEST_FAIL_AT_PASS", "2")
    rc = cli.main(["render", "cornell", "--width", "24", "--height", "24", "--spp", "6", "--quiet", "-o", str(out)])
    assert rc == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("caustica: error: the render failed after 2 passes: pass 2 failed")
    assert err[0].endswith(f"wrote the image of those passes to {out}")
    assert np.array_equal(caustica.read_image(out), expected)

    monkeypatch.setenv("CAUSTICA_TEST_FAIL_AT_PASS", "0")
    out0 = tmp_path / "none.exr"
    assert cli.main(["render", "cornell", "--width", "24", "--height", "24", "--quiet", "-o", str(out0)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["caustica: error: the render failed: pass 0 failed (CAUSTICA_TEST_FAIL_AT_PASS)"]
    assert not out0.exists()
