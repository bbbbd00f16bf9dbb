"""The one exception the client raises for an answer the server refused."""
from __future__ import annotations

import json
from typing import Mapping, Optional


class SoftgraspError(Exception):
    """A 4xx or 5xx answer, with what the server's error body says.

    Every error answer of the service has the body ``{"error": {"code", "message", "field"}}``.

    Attributes:
        status: the HTTP status, e.g. 400, 415, 422, 503.
        code: the server's stable snake_case code, e.g. ``invalid_argument``,
            ``unsupported_media_type``, ``unprocessable``, ``service_unavailable``.
        message: what is wrong and what is expected, in the server's words.
        field: the request field at fault (``top_k``, ``depth``, ``pose.orientation_wxyz``), or
            None when the error is not about one field.
        retry_after: seconds from the ``Retry-After`` header (503 when no robot is alive), else
            None.
    """

    def __init__(self, status: int, code: str, message: str, field: Optional[str] = None,
                 retry_after: Optional[float] = None) -> None:
        self.status = status
        self.code = code
        self.message = message
        self.field = field
        self.retry_after = retry_after
        super().__init__(str(self))

    def __str__(self) -> str:
        where = f" (field {self.field})" if self.field else ""
        return f"{self.status} {self.code}{where}: {self.message}"

    @classmethod
    def from_answer(cls, status: int, headers: Mapping[str, str], body: bytes) -> "SoftgraspError":
        """Reads the error body; a body that is not the service's JSON becomes the message."""
        code, message, field = "http_error", body.decode("utf-8", "replace").strip()[:500], None
        try:
            error = json.loads(body)["error"]
            code, message, field = str(error["code"]), str(error["message"]), error.get("field")
        except (ValueError, KeyError, TypeError):
            pass
        retry_after: Optional[float] = None
        try:
            retry_after = float(headers.get("Retry-After") or "")
        except ValueError:
            pass
        return cls(status, code, message or f"HTTP {status}", field, retry_after)
