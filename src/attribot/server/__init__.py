"""The remote model server (the paper's "computing cluster" side): detector, VQA and language backends
behind HTTP with dynamic batching. Its client is the `remote:URL` backend (`attribot.models.remote`).

FastAPI and uvicorn are imported only when an app is created or run (extra `attribot[server]`).
"""

from attribot.server.app import ServerConfig, create_app
from attribot.server.batching import Batcher, Served
from attribot.server.model_process import ProcessDetector, ProcessVisualQA, start_model_process
from attribot.server.run import (
    ServerThread,
    build_served_backends,
    check_bind,
    close_backends,
    listen_socket,
    serve_models,
    served_specs,
)

__all__ = [
    "ServerConfig",
    "create_app",
    "Batcher",
    "Served",
    "ServerThread",
    "build_served_backends",
    "close_backends",
    "start_model_process",
    "ProcessDetector",
    "ProcessVisualQA",
    "served_specs",
    "check_bind",
    "listen_socket",
    "serve_models",
]
