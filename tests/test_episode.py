"""Episode videos: `--save` in a world writes episode.mp4 (a card with the query, then the robot camera beside
a room camera with the action and the values read underneath, then a card with the answer) that a video
library opens again."""

from __future__ import annotations

import io
import json
import os
import signal
import stat

import av
import numpy as np
import pytest

from attribot.config import SceneConfig, load_settings
from attribot.session import Scene, ask, run_program
from attribot.video import VideoWriter


def _decode(path) -> list[np.ndarray]:
    """The frames as a viewer sees them, one per frame time: a held frame (encoded once, with a longer
    duration) repeated for as long as it is shown."""
    with av.open(str(path)) as container:
        return _shown(container)


def _shown(container) -> list[np.ndarray]:
    stream = container.streams.video[0]
    tick = 1 / (float(stream.time_base) * float(stream.base_rate))  # pts per frame time (the writer's fps)
    frames = [(f.pts, f.to_ndarray(format="rgb24")) for f in container.decode(video=0)]
    out = []
    for (pts, rgb), (after, _) in zip(frames, frames[1:] + [(frames[-1][0] + tick, None)], strict=True):
        out += [rgb] * max(1, round((after - pts) / tick))
    return out


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


def test_a_held_frame_is_encoded_once_and_shown_for_its_repeats():
    writer = VideoWriter(fps=10)
    writer.add(np.full((48, 64, 3), (200, 30, 30), np.uint8), repeat=25)  # a card, 2.5 s
    writer.add(np.full((48, 64, 3), (30, 200, 30), np.uint8))
    writer.add(np.full((48, 64, 3), (30, 30, 200), np.uint8), repeat=40)  # the closing card, 4 s
    data = writer.finish()
    import io

    with av.open(io.BytesIO(data)) as container:
        encoded = sum(1 for _ in container.decode(video=0))
    with av.open(io.BytesIO(data)) as container:
        shown = _shown(container)
    assert encoded <= 4 and writer.frames == 66
    # the last frame is shown for its whole time too (one more frame ends it)
    assert 64 <= len(shown) <= 67
    reds = sum(1 for f in shown if f[..., 0].mean() > 150)
    blues = sum(1 for f in shown if f[..., 2].mean() > 150)
    assert reds == 25 and 39 <= blues <= 41


def _decode_bytes(data: bytes) -> list[np.ndarray]:
    import io

    with av.open(io.BytesIO(data)) as container:
        return _shown(container)


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
    # ten frames a second of sim time: weighing three objects takes many seconds
    assert len(frames) >= 100 and frames[0].shape == (564, 1280, 3)
    # the cards (plain dark backgrounds around text) open and close it; the episode lies between them
    title, closing = frames[0], frames[-1]
    assert np.median(title) < 40 and np.median(closing[:, 640:]) < 40
    episode = [f for f in frames if np.median(f[:480]) > 60]
    assert len(episode) >= 80
    first, last = episode[0], episode[-1]
    assert (
        np.abs(first[:480, :640].astype(int) - last[:480, :640].astype(int)).mean() > 1.0
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
    assert len(frames) >= 1 and frames[0].shape == (564, 1280, 3)
    # (a still image has no episode: tests/test_ask.py::test_image_mode_runs_through_a_real_detector_and_vqa)


def test_a_closest_object_query_gives_enough_frames_to_follow_each_turn_of_the_head(tmp_path):
    ask("Which object is the closest?", Scene(SceneConfig()), load_settings(), save_dir=tmp_path / "c")
    frames = _decode(tmp_path / "c" / "episode.mp4")
    episode = [f for f in frames if np.median(f[:480]) > 60]  # the cards left out
    assert len(episode) >= 40  # ten a second of sim time, each new caption held for 0.8 s (was 10 in all)


def test_captions_name_the_object_and_the_value_read():
    from attribot.api.robot import Measurement, object_name

    weighed = Measurement(
        kind="weight", object_id="computer_mouse_1", label="object", value=0.0973, unit="kg", newtons=0.954
    )
    assert weighed.describe() == "computer mouse 1: 0.097 kg (0.95 N)"
    ranged = Measurement(kind="distance", object_id=None, label="mug", value=1.2112, unit="m")
    assert ranged.describe() == "mug: 1.211 m"
    assert object_name(None, "") == "the object"


def test_the_robot_says_what_it_does_to_which_object(tmp_path):
    from attribot.api.robot import Robot
    from attribot.embodiments.base import EMBODIMENTS

    world = EMBODIMENTS.get("mujoco")(SceneConfig(seed=0))
    try:
        from attribot.skills.perception import Perception

        robot = Robot(sensors=["camera", "distance"], world=world)
        image = robot.look(Perception.from_settings(load_settings()), survey=False)
        mug = next(p for p in image.find("object") if p.object_id == "mug_0")
        robot.measure_distance(mug)
        assert robot.activity == "measuring the distance to mug 0"
        assert (robot.acting_on, robot.acting_on_id) == ("mug 0", "mug_0")
        assert robot.measurements[-1].describe().startswith("mug 0: 1.")
    finally:
        world.close()


def test_a_deadline_signal_in_the_main_thread_never_breaks_the_video():
    """The run's deadline cuts a host call with a signal that raises in the main thread
    (attribot.runner.process); one that landed while PyAV's muxer called back into Python broke the container,
    and the whole saved run was lost at finish(). Frames are encoded on the writer's own thread."""

    class Cut(BaseException):
        pass

    armed = [False]

    def cut(signum, frame):
        if armed[0]:
            armed[0] = False
            raise Cut()

    previous = signal.signal(signal.SIGALRM, cut)
    writer = VideoWriter(fps=10)
    rng = np.random.default_rng(0)
    cuts = 0
    signal.setitimer(signal.ITIMER_REAL, 0.0003, 0.0003)
    try:
        for _ in range(120):
            image = rng.integers(0, 255, (96, 128, 3), dtype=np.uint8)
            try:
                armed[0] = True
                writer.add(image)
                armed[0] = False
            except Cut:
                cuts += 1
    finally:
        armed[0] = False
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert cuts > 0  # the signal did land during add()
    data = writer.finish()
    with av.open(io.BytesIO(data)) as container:
        assert len(_shown(container)) >= 120 - cuts


def test_a_video_that_cannot_be_finished_leaves_the_rest_of_the_saved_run(tmp_path, monkeypatch):
    from attribot.embodiments.episode import EpisodeRecorder

    def broken(self, *args, **kwargs):
        raise OSError("the encoder failed")

    monkeypatch.setattr(EpisodeRecorder, "finish", broken)
    out = tmp_path / "run"
    with pytest.warns(RuntimeWarning, match="episode video could not be finished"):
        answer = ask("Which object is the closest?", Scene(SceneConfig()), load_settings(), save_dir=out)
    assert answer.ok
    saved = json.loads((out / "answer.json").read_text())
    assert saved["answer"] == answer.answer
    assert {"program.py", "settings.json", "run.json", "answer.png"} <= {p.name for p in out.iterdir()}
    assert not (out / "episode.mp4").exists()
