"""Read back the scene recording a playback page embeds, independently of viser's own code.

viser's ``as_html`` puts the recording in the page as ``window.__VISER_EMBED_DATA__``: base64 of
an 8-byte little-endian size followed by a zstd stream of [8-byte msgpack length][msgpack]
[binary buffers, each 8-byte aligned]. The msgpack holds ``durationSeconds`` and ``messages``,
a list of [time, message]; numpy arrays in a message are placeholders
``{"__binary_index": i, "dtype": "<f4"}`` for the i-th buffer (``binaryBufferLengths``).
"""

from __future__ import annotations

import base64
import re

import msgspec
import numpy as np
import zstandard


def recording(page: str) -> dict:
    """The decoded recording of a page: ``durationSeconds`` and ``messages`` [(time, dict)],
    with every array placeholder replaced by its numpy array."""
    match = re.search(r'window\.__VISER_EMBED_DATA__="([A-Za-z0-9+/=]+)"', page)
    assert match, "the page embeds no viser recording"
    raw = base64.b64decode(match.group(1))
    size = int.from_bytes(raw[:8], "little")
    inner = zstandard.ZstdDecompressor().decompress(raw[8:], max_output_size=size)
    length = int.from_bytes(inner[:8], "little")
    payload = msgspec.msgpack.decode(inner[8 : 8 + length])
    buffers, offset = [], 8 + length
    for nbytes in payload["binaryBufferLengths"]:
        offset += (8 - offset % 8) % 8
        buffers.append(inner[offset : offset + nbytes])
        offset += nbytes

    def resolve(value):
        if isinstance(value, dict):
            if "__binary_index" in value and "dtype" in value:
                return np.frombuffer(buffers[value["__binary_index"]], dtype=value["dtype"])
            return {key: resolve(item) for key, item in value.items()}
        if isinstance(value, list):
            return [resolve(item) for item in value]
        return value

    payload["messages"] = [(time, resolve(message)) for time, message in payload["messages"]]
    return payload


def node_values(record: dict, message_type: str, node: str, field: str) -> list:
    """[(time, value)] of ``field`` in the ``message_type`` messages about scene node ``node``."""
    return [
        (time, message[field])
        for time, message in record["messages"]
        if message["type"] == message_type and message.get("name") == node
    ]


def node_updates(record: dict, node: str, prop: str) -> list:
    """[(time, value)] of a node's property ``prop`` set after it was made (update messages)."""
    return [
        (time, message["updates"][prop])
        for time, message in record["messages"]
        if message["type"] == "SceneNodeUpdateMessage"
        and message["name"] == node
        and prop in message["updates"]
    ]


def value_at(history: list, time: float):
    """The last value of a [(time, value)] history set at or before ``time``."""
    earlier = [value for when, value in history if when <= time + 1e-9]
    assert earlier, f"nothing set by t = {time}"
    return earlier[-1]
