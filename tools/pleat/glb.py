"""The GLB container (glTF 2.0's binary form): a 12-byte header and a table of chunks, the first JSON, then an
optional binary one. Read here once for both glTF readers (pleat.garment.meshio's meshes and pleat.motion.gltf's
animations); each turns the ValueError into its own one-line file error."""
import struct

GLB_MAGIC = b"glTF"
GLB_VERSION = 2
GLB_JSON = 0x4E4F534A                 # "JSON"
GLB_BIN = 0x004E4942                  # "BIN\0"


def glb_chunks(data):
    """(JSON chunk bytes, BIN chunk bytes or None) of a GLB, after checking the header, the declared length and every
    chunk's bounds (a ValueError saying what is wrong); structure before values, nothing is decoded here."""
    if len(data) < 20:
        raise ValueError(f"is {len(data)} bytes: too short for a GLB file (12-byte header and a chunk)")
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    if magic != GLB_MAGIC:
        raise ValueError(f"does not start with 'glTF' (found {magic!r}): not a GLB file")
    if version != GLB_VERSION:
        raise ValueError(f"is GLB version {version}; only glTF 2.0 is read")
    if length != len(data):
        raise ValueError(f"header says {length} bytes, the file has {len(data)} (truncated?)")
    chunks, at = [], 12
    while at < len(data):
        if at + 8 > len(data):
            raise ValueError(f"chunk header at byte {at} runs past the end of the file")
        size, kind = struct.unpack_from("<II", data, at)
        if at + 8 + size > len(data):
            raise ValueError(f"chunk at byte {at} says {size} bytes, only {len(data) - at - 8} are left")
        chunks.append((kind, data[at + 8:at + 8 + size]))
        at += 8 + size
    if not chunks or chunks[0][0] != GLB_JSON:
        raise ValueError("the first GLB chunk is not JSON")
    return chunks[0][1], next((c for kind, c in chunks[1:] if kind == GLB_BIN), None)
