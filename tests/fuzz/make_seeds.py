# SPDX-License-Identifier: Apache-2.0
"""Seed corpora for the libFuzzer targets of tests/fuzz, from real inputs.

    python tests/fuzz/make_seeds.py OUTDIR

writes OUTDIR/frames/ (for fuzz_node and fuzz_plant_bus: every frame of
protocol/test_vectors.json, valid and malformed, in the targets' input
format: a 4-byte header id low, id high | bus << 6, len, flags, then the
payload; each frame on each of the three buses) and OUTDIR/scenario/ (for
fuzz_scenario: the demo's scenario and the paper's, as stewart.closedloop
writes them, tests/fuzz/seeds/*.scenario, and a `play` of a small CSV
written next to them).
"""
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))

from stewart import closedloop  # noqa: E402


def frame_bytes(frame_id: int, data: bytes, bus: int) -> bytes:
    return bytes([frame_id & 0xFF, ((frame_id >> 8) & 0x07) | (bus << 6), len(data), 0]) + data


def frames(out: Path) -> int:
    vectors = json.loads((ROOT / "protocol" / "test_vectors.json").read_text())
    out.mkdir(parents=True, exist_ok=True)
    n = 0
    for i, v in enumerate(vectors["vectors"] + vectors["malformed"]):
        data = bytes.fromhex(v["data"])
        seed = b"".join(frame_bytes(v["frame_id"], data, bus) for bus in range(3))
        (out / f"vector_{i:03d}").write_bytes(seed)
        n += 1
    return n


def scenarios(out: Path) -> int:
    out.mkdir(parents=True, exist_ok=True)
    texts = {"demo": closedloop.demo_scenario(), "paper": closedloop.paper_scenario()}
    for f in sorted((ROOT / "tests" / "fuzz" / "seeds").glob("*.scenario")):
        texts[f.stem] = f.read_text()
    csv = (out.parent / "play.csv").resolve()  # absolute: the target runs elsewhere
    csv.write_text("t,x,y,z,roll,pitch,yaw\n0,0,0,2.5,0,0,0\n0.002,0.001,0,2.5,0,0,0.001\n")
    texts["play"] = f"cmd ENGAGE\nplay {csv}\nmark played\n"
    for name, text in texts.items():
        (out / f"{name}.scenario").write_text(text)
    return len(texts)


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    out = Path(sys.argv[1])
    nf = frames(out / "frames")
    ns = scenarios(out / "scenario")
    print(f"seeds: {nf} frame files, {ns} scenarios in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
