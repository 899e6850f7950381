"""Golden frames: what the robot's camera and the room camera see of each scene layout (seed 0, 160x120)
is compared with a committed image under tests/artifacts/golden/, within an RMS tolerance, as dm_control
compares its golden frames. A failure saves the expected, the actual and a difference image (grey where
they agree) in tests/golden-failures/ and says so.

Regenerate them on purpose, after a change meant to alter how scenes look (objects, materials, lighting,
cameras), with `.venv/bin/python tests/test_golden_frames.py`; look at the new images before committing
them. The tolerance: software rendering through EGL (Mesa's llvmpipe) and through OSMesa gives the same
pixels here (RMS 0.0); a view turned by one pixel differs by about 9, one object's 15x15 px patch made
brighter by 60 by about 6.5. 4.0 lets rendering noise pass and catches those.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from attribot.config import SceneConfig
from attribot.embodiments.mujoco import MujocoWorld
from attribot.sim.scene_plan import LAYOUTS

GOLDEN = Path(__file__).parent / "artifacts" / "golden"
FAILURES = Path(__file__).parent / "golden-failures"  # not committed (.gitignore: *.png)
WIDTH, HEIGHT, SEED = 160, 120, 0
TOLERANCE_RMS = 4.0
REGENERATE = ".venv/bin/python tests/test_golden_frames.py"


def render(layout: str) -> dict[str, np.ndarray]:
    """The robot camera's and the room camera's first view of `layout`, by name."""
    with MujocoWorld(SceneConfig(layout=layout, seed=SEED, width=WIDTH, height=HEIGHT)) as world:
        return {"robot": world.observe().rgb, "room": world.sim.room_view()}


def rms(expected: np.ndarray, actual: np.ndarray) -> float:
    """The root mean square difference of two uint8 images, in grey levels (0 to 255)."""
    diff = expected.astype(np.int64) - actual.astype(np.int64)
    return float(np.sqrt(np.mean(diff**2)))


def assert_close(name: str, expected: np.ndarray, actual: np.ndarray, failures: Path = FAILURES) -> None:
    """Fail, saving `name`-expected/-actual/-difference.png in `failures`, when the images differ in size
    or by more than the tolerance."""
    error = rms(expected, actual) if expected.shape == actual.shape else float("inf")
    if error <= TOLERANCE_RMS:
        return
    failures.mkdir(parents=True, exist_ok=True)
    Image.fromarray(expected).save(failures / f"{name}-expected.png")
    Image.fromarray(actual).save(failures / f"{name}-actual.png")
    if expected.shape == actual.shape:
        difference = (actual.astype(np.float64) - expected + 255.0) / 2.0
        Image.fromarray(difference.astype(np.uint8)).save(failures / f"{name}-difference.png")
    raise AssertionError(
        f"{name} differs from its golden frame: RMS {error:.2f} > {TOLERANCE_RMS} (shapes {expected.shape}, "
        f"{actual.shape}); the expected, actual and difference images are in {failures}. If the change "
        f"is meant, regenerate the golden frames with `{REGENERATE}` and commit them."
    )


@pytest.mark.parametrize("layout", LAYOUTS.names())
def test_each_layout_looks_as_its_golden_frames(layout):
    for view, actual in render(layout).items():
        path = GOLDEN / f"{layout}-{view}.png"
        assert path.is_file(), f"no golden frame {path}: make it with `{REGENERATE}` and commit it"
        assert_close(f"{layout}-{view}", np.asarray(Image.open(path).convert("RGB")), actual)


def test_a_changed_object_fails_and_leaves_the_images_to_look_at(tmp_path):
    expected = np.asarray(Image.open(GOLDEN / "household-robot.png").convert("RGB"))
    actual = expected.copy()
    actual[50:65, 70:85] = np.clip(actual[50:65, 70:85].astype(int) + 60, 0, 255)
    with pytest.raises(AssertionError, match=f"RMS 6.* > {TOLERANCE_RMS}.*{tmp_path}"):
        assert_close("changed", expected, actual, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "changed-actual.png",
        "changed-difference.png",
        "changed-expected.png",
    ]
    difference = np.asarray(Image.open(tmp_path / "changed-difference.png"))
    assert (difference[0, 0] == 127).all() and (difference[57, 77] > 127).all()  # grey where alike
    assert_close("same", expected, expected.copy(), tmp_path)  # and the unchanged image passes


def regenerate() -> None:
    """Render every layout and write its golden frames."""
    GOLDEN.mkdir(exist_ok=True)
    for layout in LAYOUTS.names():
        for view, rgb in render(layout).items():
            path = GOLDEN / f"{layout}-{view}.png"
            Image.fromarray(rgb).save(path)
            print(f"wrote {path}")


if __name__ == "__main__":
    regenerate()
