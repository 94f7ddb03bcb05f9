"""The byte format of a serialized FMU state (fmi2SerializeFMUstate / fmi2DeSerializeFMUstate).

A state blob comes from the importer, so reading it must never run code it names (no pickle, no class names): the
format is data only, a checked envelope around a JSON tree of plain values and the raw bytes of its arrays.

    envelope (HEADER, 96 bytes, little endian)
      magic       b"RVFMUSTATE"                        10 bytes
      version     uint16 (FORMAT_VERSION)
      length      uint64: bytes after the envelope
      crc32       uint32: zlib CRC-32 of the bytes after the envelope
      tag         72 bytes, NUL-padded UTF-8: "<model identifier>/<build fingerprint>"
    payload
      JSON length uint32, then the JSON (UTF-8): the tree
      the arrays' bytes, back to back, in the order of the tree

A node of the tree is a JSON null, boolean, string, integer or float (non-finite floats as {"f": "nan"|"inf"|
"-inf"}), a list, a dict with string keys, or an array {"a": dtype, "shape": [...], "offset": n, "size": n} with a
dtype from a short allow-list. The tag names the model and the build (the bundled package's name carries a hash of
the sources, fmu_src/build.py): a state is read only by a build of the same sources, which is what the shim checks
before Python sees the bytes (fmu_src/c/fmi2_status_shim.c reads this envelope with the same layout). Anything
else is refused with a ValueError that says what was wrong; nothing of a refused blob is used.
"""
from __future__ import annotations

import json
import math
import struct
import zlib

import numpy as np

MAGIC = b"RVFMUSTATE"
FORMAT_VERSION = 2
TAG_SIZE = 72
HEADER = struct.Struct(f"<{len(MAGIC)}sHQI{TAG_SIZE}s")
ARRAY_DTYPES = {"<f8", "<i8", "<i4", "|b1", "|u1"}
NON_FINITE = {"nan": math.nan, "inf": math.inf, "-inf": -math.inf}
MAX_DEPTH = 32


def tag_of(model: str, fingerprint: str) -> bytes:
    tag = f"{model}/{fingerprint}".encode("utf-8")
    if len(tag) > TAG_SIZE:
        raise ValueError(f"state tag {tag!r} is longer than {TAG_SIZE} bytes")
    return tag


def encode(tree, model: str, fingerprint: str) -> bytes:
    """The bytes of `tree`: dicts with string keys, lists and tuples, None, bools, ints, floats, strings and numpy
    arrays of the allowed dtypes. Anything else is a TypeError (a bug of the slave, not of the importer)."""
    chunks: list[bytes] = []
    offset = 0

    def node(value, depth=0):
        nonlocal offset
        if depth > MAX_DEPTH:
            raise TypeError("FMU state nested too deeply")
        if value is None or isinstance(value, (bool, str)):
            return value
        if isinstance(value, np.bool_):
            return bool(value)
        if isinstance(value, (int, np.integer)):
            return int(value)
        if isinstance(value, (float, np.floating)):
            value = float(value)
            return value if math.isfinite(value) else {"f": repr(value)}
        if isinstance(value, np.ndarray):
            array = np.ascontiguousarray(value)
            if array.dtype.str not in ARRAY_DTYPES:
                raise TypeError(f"array of dtype {array.dtype.str} cannot be saved in an FMU state")
            data = array.tobytes()
            chunks.append(data)
            entry = {"a": array.dtype.str, "shape": list(array.shape), "offset": offset, "size": len(data)}
            offset += len(data)
            return entry
        if isinstance(value, dict):
            if not all(isinstance(key, str) for key in value):
                raise TypeError(f"dict keys of an FMU state must be strings: {list(value)[:5]}")
            return {"d": {key: node(item, depth + 1) for key, item in value.items()}}
        if isinstance(value, (list, tuple)):
            return [node(item, depth + 1) for item in value]
        raise TypeError(f"a {type(value).__name__} cannot be saved in an FMU state")

    description = json.dumps(node(tree), separators=(",", ":"), allow_nan=False).encode("utf-8")
    payload = struct.pack("<I", len(description)) + description + b"".join(chunks)
    return HEADER.pack(MAGIC, FORMAT_VERSION, len(payload), zlib.crc32(payload), tag_of(model, fingerprint)) + payload


def check_envelope(blob: bytes, model: str, fingerprint: str) -> memoryview:
    """The payload of `blob` after checking magic, version, length, checksum and tag; ValueError otherwise."""
    if len(blob) < HEADER.size or not bytes(blob[:len(MAGIC)]) == MAGIC:
        raise ValueError(f"not a serialized state of this FMU ({len(blob)} bytes without the {MAGIC.decode()} "
                         f"header)")
    magic, version, length, checksum, tag = HEADER.unpack_from(blob)
    if version != FORMAT_VERSION:
        raise ValueError(f"state format version {version}; this FMU reads version {FORMAT_VERSION}")
    if HEADER.size + length != len(blob):
        raise ValueError(f"state of {len(blob)} bytes, its header announces {HEADER.size + length} (truncated or "
                         f"extended)")
    payload = memoryview(blob)[HEADER.size:]
    if zlib.crc32(payload) != checksum:
        raise ValueError("state checksum mismatch (the bytes were changed after serialization)")
    if tag.rstrip(b"\0") != tag_of(model, fingerprint):
        raise ValueError(f"state of {tag.rstrip(bytes(1)).decode('utf-8', 'replace')[:80]!r}, this FMU is "
                         f"{tag_of(model, fingerprint).decode()!r} (another model or another build)")
    return payload


def decode(blob: bytes, model: str, fingerprint: str):
    """The tree saved by `encode`; ValueError if `blob` is not a state of this model and build."""
    payload = check_envelope(bytes(blob), model, fingerprint)
    if len(payload) < 4:
        raise ValueError("state payload too short")
    (length,) = struct.unpack_from("<I", payload)
    if 4 + length > len(payload):
        raise ValueError("state description runs past the end of the state")
    try:
        description = json.loads(bytes(payload[4:4 + length]).decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as error:
        raise ValueError(f"state description is not valid JSON: {str(error)[:120]}") from None
    data = payload[4 + length:]

    def value(entry, depth=0):
        if depth > MAX_DEPTH:
            raise ValueError("state nested too deeply")
        if entry is None or isinstance(entry, (bool, int, float, str)):
            return entry
        if isinstance(entry, list):
            return [value(item, depth + 1) for item in entry]
        if isinstance(entry, dict) and set(entry) == {"d"} and isinstance(entry["d"], dict):
            return {key: value(item, depth + 1) for key, item in entry["d"].items()}
        if isinstance(entry, dict) and set(entry) == {"f"} and isinstance(entry["f"], str) \
                and entry["f"] in NON_FINITE:
            return NON_FINITE[entry["f"]]
        if isinstance(entry, dict) and "a" in entry:
            return _array(entry, data)
        raise ValueError(f"malformed state node {str(entry)[:80]}")

    return value(description)


def _array(entry: dict, data: memoryview) -> np.ndarray:
    dtype, shape = entry.get("a"), entry.get("shape")
    offset, size = entry.get("offset"), entry.get("size")
    if not isinstance(dtype, str) or dtype not in ARRAY_DTYPES:
        raise ValueError(f"state array of dtype {str(dtype)[:40]!r}: allowed {sorted(ARRAY_DTYPES)}")
    if (not isinstance(shape, list) or len(shape) > 8
            or not all(isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in [*shape, offset, size])):
        raise ValueError("state array with a malformed shape, offset or size")
    if math.prod(shape) * np.dtype(dtype).itemsize != size or offset + size > len(data):
        raise ValueError(f"state array of shape {shape} does not fit its {size} bytes at offset {offset} "
                         f"(the state holds {len(data)} bytes of arrays)")
    return np.frombuffer(data[offset:offset + size], dtype=dtype).reshape(shape).copy()
