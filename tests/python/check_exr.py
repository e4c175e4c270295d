"""Reads an EXR written by hdrvis with the OpenEXR reference library and checks its channels.

Usage: check_exr.py FILE.exr CHANNEL[=TYPE] ... [--pixel X,Y,CHANNEL,VALUE]...
       [--absent CHANNEL]... [--compression NAME]
TYPE is FLOAT or HALF (default FLOAT); NAME as OpenEXR's enum without _COMPRESSION (ZIP, PIZ). Exit 0 when every check passes, 1 with one line per
failure, 77 when the OpenEXR module is missing (the Rust test turns that into a skip or, under
HDRVIS_REQUIRE_PYTHON=1, a failure).
"""
import sys

try:
    import OpenEXR
    import numpy as np
except ImportError as e:  # pragma: no cover - environment check
    print(f"missing python module: {e}", file=sys.stderr)
    sys.exit(77)


def main(argv):
    path = argv[0]
    expected = {}
    pixels = []
    absent = []
    compression = None
    args = iter(argv[1:])
    for a in args:
        if a == "--pixel":
            x, y, ch, v = next(args).split(",")
            pixels.append((int(x), int(y), ch, float(v)))
        elif a == "--absent":
            absent.append(next(args))
        elif a == "--compression":
            compression = next(args)
        else:
            name, _, typ = a.partition("=")
            expected[name] = typ or "FLOAT"
    failures = []
    with OpenEXR.File(path) as f:
        header = f.header()
        channels = f.channels()
        # Channels may be grouped as "RGBA" by the bindings; look at the header's channel list.
        listed = {c.name: c for c in header["channels"]} if "channels" in header else {}
        # The bindings group channels ("RGBA"); the header lists each one by name, and the
        # grouped array's dtype gives the sample type.
        dtypes = {}
        for key, ch in channels.items():
            members = list(key) if key in ("RGB", "RGBA") else [key]
            for m in members:
                dtypes[m] = np.asarray(ch.pixels).dtype
        kind = {np.dtype("float32"): "FLOAT", np.dtype("float16"): "HALF", np.dtype("uint32"): "UINT"}
        for name, typ in expected.items():
            if name not in listed:
                failures.append(f"channel {name} missing; file has {sorted(listed)}")
                continue
            got = kind.get(dtypes.get(name), str(dtypes.get(name)))
            if got != typ:
                failures.append(f"channel {name}: expected {typ}, got {got}")
        for name in absent:
            if name in listed:
                failures.append(f"channel {name} present; expected it left out")
        if compression is not None:
            got = str(header["compression"]).split(".")[-1].split(":")[0]
            if got != f"{compression}_COMPRESSION":
                failures.append(f"compression: expected {compression}, got {got}")
        for x, y, ch, v in pixels:
            arr = None
            if ch in channels:
                arr = channels[ch].pixels
            elif "RGBA" in channels and ch in "RGBA":
                arr = channels["RGBA"].pixels[..., "RGBA".index(ch)]
            elif "RGB" in channels and ch in "RGB":
                arr = channels["RGB"].pixels[..., "RGB".index(ch)]
            if arr is None:
                failures.append(f"pixel check: channel {ch} not readable")
                continue
            got = float(np.asarray(arr)[y, x])
            if not np.isclose(got, v, rtol=1e-6, atol=0.0):
                failures.append(f"pixel ({x},{y}) {ch}: expected {v}, got {got}")
    for line in failures:
        print(line)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
