"""Backends in a child process of the server: same answers as in-process, errors that keep their kind,
a child that dies is replaced, shared memory is freed, and the server serves through it without mix-ups.

The stand-in backends compute their answers from the image (the box of its bright pixels, its mean
colour), so a frame read from the wrong place in shared memory, or an answer given to the wrong request,
is caught. They are built in the child from a factory, as the server does with a backend spec.
"""

from __future__ import annotations

import functools
import os
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from attribot.config import Settings
from attribot.errors import BackendError, ConfigError, InputError
from attribot.frame import Frame
from attribot.server import (
    ProcessDetector,
    ProcessVisualQA,
    ServerConfig,
    ServerThread,
    build_served_backends,
    close_backends,
    create_app,
    start_model_process,
)
from attribot.server.model_process import ModelProcess, backend_factory
from conftest import BrightBoxDetector, alive, frame_with_box


class MeanColourVQA:
    name = "test:mean-colour"

    def answer(self, frame: Frame, question: str) -> str:
        return f"{question}:{int(frame.rgb.mean())}"


def failing_factory() -> None:
    raise ConfigError("no model at /nowhere", "give a folder that holds a model")


@pytest.fixture(scope="module")
def detector():
    proc = start_model_process("detector", BrightBoxDetector)
    yield proc
    proc.close()


def test_a_batch_of_mixed_sizes_is_read_back_frame_by_frame(detector):
    boxes = [(3, 4, 20, 30), (50, 10, 90, 70), (0, 0, 5, 5), (100, 200, 300, 230)]
    sizes = [(40, 60), (120, 160), (8, 8), (240, 320)]
    frames = [frame_with_box(h, w, b) for (h, w), b in zip(sizes, boxes, strict=True)]
    out = detector.detect_batch(frames, [[f"q{i}"] for i in range(4)])
    assert [d[0].box for d in out] == [tuple(map(float, b)) for b in boxes]
    assert [d[0].label for d in out] == [f"q{i}@{detector.pid}" for i in range(4)]
    assert detector.pid != os.getpid() and detector.name == "test:bright-box"


def test_a_larger_batch_gets_a_larger_block(detector):
    small = detector.detect_batch([frame_with_box(16, 16, (1, 1, 4, 4))], [["a"]])
    big_frames = [frame_with_box(480, 640, (i, i, 100 + i, 50 + i)) for i in range(8)]
    big = detector.detect_batch(big_frames, [["b"]] * 8)
    assert small[0][0].box == (1.0, 1.0, 4.0, 4.0)
    assert [d[0].box for d in big] == [(float(i), float(i), 100.0 + i, 50.0 + i) for i in range(8)]


def test_errors_keep_their_kind_and_the_child_keeps_serving(detector):
    pid = detector.pid
    with pytest.raises(InputError, match="not acceptable") as info:
        detector.detect(frame_with_box(10, 10, (0, 0, 5, 5)), ["bad-input"])
    assert info.value.fix == "send another one"
    with pytest.raises(BackendError, match="RuntimeError: the model crashed on purpose"):
        detector.detect(frame_with_box(10, 10, (0, 0, 5, 5)), ["crash"])
    assert detector.detect(frame_with_box(10, 10, (2, 2, 5, 5)), ["ok"])[0].box == (2.0, 2.0, 5.0, 5.0)
    assert detector.pid == pid and detector.restarts == 0


def test_a_child_that_dies_fails_its_batch_and_is_started_again():
    proc = start_model_process("detector", BrightBoxDetector)
    try:
        first = proc.pid
        with pytest.raises(BackendError, match=r"exited \(code 3\) while serving a batch of 1") as info:
            proc.detect(frame_with_box(10, 10, (0, 0, 5, 5)), ["exit"])
        assert "started again" in (info.value.fix or "")
        assert proc.pid is None
        dets = proc.detect(frame_with_box(10, 10, (1, 2, 3, 4)), ["again"])
        assert dets[0].box == (1.0, 2.0, 3.0, 4.0)
        assert proc.pid not in (None, first) and proc.restarts == 1
    finally:
        proc.close()


def test_close_ends_the_child_and_frees_the_shared_memory():
    proc = start_model_process("vqa", MeanColourVQA)
    assert isinstance(proc, ProcessVisualQA)
    rgb = np.full((20, 30, 3), 77, np.uint8)
    assert proc.answer_batch([Frame(rgb=rgb), Frame(rgb=rgb // 7)], ["x", "y"]) == ["x:77", "y:11"]
    child, block = proc._process, proc._block
    assert block is not None and Path("/dev/shm", block.name).exists()
    proc.close()
    assert not child.is_alive() and not Path("/dev/shm", block.name).exists()
    with pytest.raises(BackendError, match="was closed"):
        proc.answer(Frame(rgb=rgb), "x")


def test_a_backend_that_cannot_load_raises_its_own_error_in_the_parent():
    started = time.monotonic()
    with pytest.raises(ConfigError, match="no model at /nowhere") as info:
        start_model_process("detector", failing_factory)
    assert info.value.fix == "give a folder that holds a model"
    assert time.monotonic() - started < 60


def test_only_image_roles_run_in_a_model_process():
    with pytest.raises(ConfigError, match="only the detector and VQA"):
        start_model_process("language", MeanColourVQA)
    with pytest.raises(TypeError):
        ModelProcess(MeanColourVQA)


def test_the_server_serves_through_the_child_without_mixing_answers(detector):
    from attribot.models.remote import RemoteClient, RemoteDetector

    boxes = [(i, 2 * i, 40 + i, 30 + 2 * i) for i in range(64)]
    app = create_app(detector=detector, config=ServerConfig(max_batch=16, batch_window_ms=5))
    with ServerThread(app) as srv, RemoteClient(srv.url, max_connections=64) as client:
        remote = RemoteDetector(client)

        def ask(i: int):
            return remote.detect(frame_with_box(240, 320, boxes[i]), [f"r{i}"])

        with ThreadPoolExecutor(64) as pool:  # 64 clients at once
            answers = list(pool.map(ask, range(64)))
        # JPEG blurs the edges by a pixel or so; the box must be this request's, not a neighbour's
        for i, dets in enumerate(answers):
            assert dets[0].label == f"r{i}@{detector.pid}"
            assert np.allclose(dets[0].box, boxes[i], atol=2)
        assert max(client.metrics().roles["detector"].batch_sizes) > 1


def test_build_served_backends_puts_the_hf_detector_in_a_child_and_matches_in_process(tmp_path):
    pytest.importorskip("torch")
    pytest.importorskip("transformers")
    from attribot.models.hf import HFDetector
    from fakes.hf_random import save_random

    folder = save_random("owlv2-tiny", tmp_path / "owl")
    settings = Settings(detector=f"hf:{folder}", detector_threshold=0.0)
    backends = build_served_backends(settings, {"detector": None, "vqa": "none", "language": "catalog"})
    try:
        assert isinstance(backends["detector"], ProcessDetector) and backends["vqa"] is None
        assert not isinstance(backends["language"], ModelProcess)  # a table lookup: no model to protect
        rng = np.random.default_rng(0)
        frames = [Frame(rgb=rng.integers(0, 256, (h, w, 3), dtype=np.uint8)) for h, w in ((48, 64), (64, 40))]
        queries = [["a cup", "a book"], ["an apple"]]
        remote = backends["detector"].detect_batch(frames, queries)
        local = HFDetector(str(folder), threshold=0.0).detect_batch(frames, queries)
        assert sum(map(len, remote)) > 0 and [len(d) for d in remote] == [len(d) for d in local]
        for a, b in zip(remote, local, strict=True):
            assert [d.label for d in a] == [d.label for d in b]
            assert np.allclose([d.box for d in a], [d.box for d in b], atol=1e-3)
    finally:
        close_backends(backends)
    assert not backends["detector"]._finalizer.alive  # closed: the child is gone


def test_factory_of_a_spec_is_picklable():
    import pickle

    factory = backend_factory("detector", "hf:/models/owl", Settings())
    again = pickle.loads(pickle.dumps(factory))
    assert isinstance(again, functools.partial) and again.args[:2] == ("detector", "hf:/models/owl")


# ---- deadlines and shutdown: a stuck model never holds the server, nothing is left behind --------------


def test_a_batch_past_its_deadline_restarts_the_child():
    proc = start_model_process("detector", BrightBoxDetector, batch_timeout_s=1.0)
    try:
        first = proc.pid
        with pytest.raises(BackendError, match="longer than 1 s"):
            proc.detect(frame_with_box(8, 8, (1, 1, 4, 4)), ["hang"])
        assert not alive(first)
        (det,) = proc.detect(frame_with_box(8, 8, (1, 1, 4, 4)), ["ok"])
        assert det.box == (1.0, 1.0, 4.0, 4.0) and proc.pid != first and proc.restarts == 1
    finally:
        proc.close()


def test_close_does_not_wait_for_a_stuck_batch():
    proc = start_model_process("detector", BrightBoxDetector)
    pid = proc.pid
    with ThreadPoolExecutor(1) as pool:
        stuck = pool.submit(proc.detect, frame_with_box(8, 8, (1, 1, 4, 4)), ["hang"])
        time.sleep(0.5)  # the child is inside the call
        proc.close()
        with pytest.raises(BackendError):
            stuck.result(timeout=10)
    assert pid is not None and not alive(pid)


def test_the_child_dies_with_its_parent(tmp_path):
    """A parent killed outright (no clean-up at all) takes its model process with it."""
    import signal
    import subprocess
    import sys

    script = (
        "import sys, time\n"
        "from attribot.server import start_model_process\n"
        "from conftest import BrightBoxDetector\n"
        "proc = start_model_process('detector', BrightBoxDetector)\n"
        "print(proc.pid, flush=True)\n"
        "time.sleep(600)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parent)}
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, env=env)
    try:
        child = int(parent.stdout.readline())
        assert alive(child)
        parent.send_signal(signal.SIGKILL)
        parent.wait(10)
        end = time.monotonic() + 5
        while alive(child) and time.monotonic() < end:
            time.sleep(0.05)
        assert not alive(child)
    finally:
        parent.kill()
        parent.wait()


def test_a_pipe_closed_twice_does_not_stop_the_shared_memory_being_freed():
    """A request thread whose child was killed under it closes the pipe as `close` does: the loser of that
    race gets EBADF, and the shutdown still frees the shared memory block."""
    from multiprocessing import shared_memory

    class ClosedAlready:
        def send(self, message: object) -> None:
            raise OSError(9, "Bad file descriptor")

        def close(self) -> None:
            raise OSError(9, "Bad file descriptor")

    block = shared_memory.SharedMemory(create=True, size=64)
    name = block.name
    ModelProcess._shutdown({"conn": ClosedAlready(), "process": None, "block": block})
    assert not Path(f"/dev/shm/{name}").exists()
