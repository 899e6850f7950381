"""Episode videos: `--save` in a world writes episode.mp4 (robot camera beside a room camera, the API call
underneath) that a video library opens again."""

from __future__ import annotations

import json
import os
import stat

import av
import numpy as np

from attribot.config import SceneConfig, load_settings
from attribot.session import Scene, ask, run_program
from attribot.video import VideoWriter


def _decode(path) -> list[np.ndarray]:
    with av.open(str(path)) as container:
        return [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]


def test_video_writer_round_trip():
    writer = VideoWriter(fps=5)
    colours = [(200, 30, 30), (30, 200, 30), (30, 30, 200)]
    for c in colours:
        writer.add(np.full((49, 65, 3), c, np.uint8))  # odd sides are cropped to even for yuv420p
    frames = _decode_bytes(writer.finish())
    assert len(frames) == 3 and frames[0].shape == (48, 64, 3)
    for frame, c in zip(frames, colours, strict=True):
        assert np.abs(frame.reshape(-1, 3).mean(axis=0) - c).max() < 12  # lossy, but the colour is kept
    assert VideoWriter().finish() == b""


def _decode_bytes(data: bytes) -> list[np.ndarray]:
    import io

    with av.open(io.BytesIO(data)) as container:
        return [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]


def test_ask_with_save_films_the_episode(tmp_path):
    out = tmp_path / "run"
    answer = ask(
        "Which object is the heaviest?",
        Scene(SceneConfig(layout="triplet", seed=3)),
        load_settings(),
        save_dir=out,
    )
    assert answer.error is None
    frames = _decode(out / "episode.mp4")
    # four frames a second of sim time: weighing three objects takes many seconds
    assert len(frames) >= 20 and frames[0].shape == (268, 640, 3)
    first, last = frames[0], frames[-1]
    assert (
        np.abs(first[:240, :320].astype(int) - last[:240, :320].astype(int)).mean() > 1.0
    )  # the camera moved
    assert stat.S_IMODE(os.stat(out / "episode.mp4").st_mode) == 0o666 & ~_umask()
    saved = json.loads((out / "answer.json").read_text())
    assert saved["object"]["id"] == answer.object.id


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_exec_with_save_films_too(tmp_path):
    program = "def execute_command(image, robot):\n    return image.find('object')[0]\n"
    run_program(
        program, Scene(SceneConfig(layout="household", seed=1)), load_settings(), save_dir=tmp_path / "a"
    )
    frames = _decode(tmp_path / "a" / "episode.mp4")
    assert len(frames) >= 1 and frames[0].shape == (268, 640, 3)
    # (a still image has no episode: tests/test_ask.py::test_image_mode_runs_through_a_real_detector_and_vqa)
