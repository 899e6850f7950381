"""A loopback OpenAI-compatible chat endpoint on pytest-httpserver, answering scripted replies."""

from __future__ import annotations

import json

__all__ = ["serve_chat_replies"]


def serve_chat_replies(httpserver, contents: list[str]) -> list[dict]:
    """A loopback OpenAI-compatible endpoint answering `contents` in turn (the last one repeats);
    returns the list that collects the request bodies."""
    from werkzeug import Response

    requests: list[dict] = []

    def handler(request):
        body = json.loads(request.data)
        requests.append(body)
        content = contents[min(len(requests), len(contents)) - 1]
        reply = {
            "id": "x",
            "object": "chat.completion",
            "created": 0,
            "model": body["model"],
            "choices": [
                {"index": 0, "finish_reason": "stop", "message": {"role": "assistant", "content": content}}
            ],
        }
        return Response(json.dumps(reply), content_type="application/json")

    httpserver.expect_request("/v1/chat/completions", method="POST").respond_with_handler(handler)
    return requests
