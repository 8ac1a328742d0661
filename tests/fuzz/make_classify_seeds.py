#!/usr/bin/env python3
# Seeds for fuzz_classify from tests/data/polygons/*.json, in the byte layout fuzz_classify.cpp decodes:
# head byte (n | 0x80 when rotation indices are prescribed), per vertex a flag byte 3 and two little-endian
# doubles, then one byte per R_i (R_i + 1). Polygons above the target's vertex limit are skipped.
#   python3 tests/fuzz/make_classify_seeds.py tests/data/polygons tests/fuzz/corpus/fuzz_classify
import json, pathlib, struct, sys

MAX_VERTICES = 48  # fuzz_classify.cpp kMaxVertices

def encode(polygon, rotation):
    out = bytearray([len(polygon) | (0x80 if rotation is not None else 0)])
    for x, y in polygon:
        out += bytes([3]) + struct.pack("<dd", x, y)
    if rotation is not None:
        out += bytes(r + 1 for r in rotation)
    return bytes(out)

src, dst = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
dst.mkdir(parents=True, exist_ok=True)
for path in sorted(src.glob("*.json")):
    doc = json.loads(path.read_text())
    if len(doc["polygon"]) > MAX_VERTICES:
        continue
    (dst / (path.stem + ".bin")).write_bytes(encode(doc["polygon"], doc.get("rotation_indices")))
    if "rotation_indices" not in doc:  # the same polygon with every R_i prescribed 0
        (dst / (path.stem + "_r0.bin")).write_bytes(encode(doc["polygon"], [0] * len(doc["polygon"])))
