"""HTTP plumbing: form values, multipart/form-data bodies and requests with a timeout."""
from __future__ import annotations

import json
import secrets
import urllib.error
import urllib.request
from dataclasses import dataclass
from typing import Any, Dict, Mapping, Optional, Sequence

import numpy as np

from .errors import SoftgraspError


@dataclass(frozen=True)
class Part:
    """A file part of a multipart/form-data body."""

    name: str
    data: bytes
    filename: str
    content_type: str = "application/octet-stream"


@dataclass(frozen=True)
class Response:
    """A 2xx answer."""

    status: int
    headers: Mapping[str, str]
    body: bytes

    def json(self) -> Any:
        return json.loads(self.body)


def form_value(value: Any) -> str:
    """A request option as the server reads it: true/false, numbers, lists comma-separated."""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (np.integer, np.floating)):
        value = value.item()
    if isinstance(value, (int, float, str)):
        return str(value)
    if isinstance(value, (Sequence, np.ndarray)):
        return ",".join(form_value(v) for v in value)
    raise TypeError(f"cannot send {type(value).__name__} as a form field")


def form_fields(options: Mapping[str, Any]) -> Dict[str, str]:
    """The options that are set (None = the server's default), as form values."""
    return {name: form_value(value) for name, value in options.items() if value is not None}


def multipart(fields: Mapping[str, str], parts: Sequence[Part]) -> tuple:
    """(body, content type) of a multipart/form-data body with these fields and file parts."""
    boundary = "softgrasp-" + secrets.token_hex(16)
    chunks = []
    for name, value in fields.items():
        chunks.append(f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"\r\n\r\n'
                      f"{value}\r\n".encode())
    for part in parts:
        chunks.append(f'--{boundary}\r\nContent-Disposition: form-data; name="{part.name}"; '
                      f'filename="{part.filename}"\r\nContent-Type: {part.content_type}\r\n\r\n'
                      .encode() + part.data + b"\r\n")
    chunks.append(f"--{boundary}--\r\n".encode())
    return b"".join(chunks), f"multipart/form-data; boundary={boundary}"


def send(method: str, url: str, *, timeout: float, body: Optional[bytes] = None,
         headers: Optional[Mapping[str, str]] = None) -> Response:
    """One request. A 4xx/5xx answer raises SoftgraspError; a server that cannot be reached or
    does not answer within ``timeout`` seconds raises the OSError urllib raises (URLError,
    TimeoutError)."""
    request = urllib.request.Request(url, data=body, method=method, headers=dict(headers or {}))
    try:
        with urllib.request.urlopen(request, timeout=timeout) as answer:
            return Response(answer.status, answer.headers, answer.read())
    except urllib.error.HTTPError as error:
        with error:
            raise SoftgraspError.from_answer(error.code, error.headers, error.read()) from None
