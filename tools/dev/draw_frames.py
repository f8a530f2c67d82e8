# SPDX-License-Identifier: Apache-2.0
"""Draws docs/reference/frames.svg: the base frame, the platform frame o',
the tool frame T on the platform and the work frame W on the ground, in a
side view (x right, z up), with the default config's tip and a work frame
tilted 20 deg.

    python3 tools/dev/draw_frames.py docs/reference/frames.svg

Standard library only; the geometry is the float64 reference's
(tools/stewart/frames.py conventions: R = Rz Ry Rx, side view of x and z).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

W, H = 760, 470
SCALE = 120.0          # px per m
ORIGIN = (150.0, 440.0)  # the base frame's o in px


def px(x: float, z: float) -> tuple[float, float]:
    return ORIGIN[0] + SCALE * x, ORIGIN[1] - SCALE * z


def axes(x: float, z: float, pitch: float, label: str, colour: str, length: float = 0.45) -> list[str]:
    """x and z axes of a frame turned by `pitch` about y (side view: +pitch turns x towards -z)."""
    ox, oz = px(x, z)
    ex = (math.cos(pitch), -math.sin(pitch))   # x axis in (x, z)
    ez = (math.sin(pitch), math.cos(pitch))    # z axis in (x, z)
    out = []
    for (dx, dz), name in ((ex, "x"), (ez, "z")):
        tx, tz = px(x + length * dx, z + length * dz)
        out.append(f'<line x1="{ox:.1f}" y1="{oz:.1f}" x2="{tx:.1f}" y2="{tz:.1f}" stroke="{colour}" '
                   f'stroke-width="2.5" marker-end="url(#arrow-{colour[1:]})"/>')
        out.append(f'<text x="{tx + 6:.1f}" y="{tz + 4:.1f}" fill="{colour}" font-size="13">{name}</text>')
    out.append(f'<circle cx="{ox:.1f}" cy="{oz:.1f}" r="4" fill="{colour}"/>')
    out.append(f'<text x="{ox - 10:.1f}" y="{oz + 20:.1f}" fill="{colour}" font-size="15" '
               f'font-weight="bold">{label}</text>')
    return out


def svg() -> str:
    colours = {"base": "#333333", "plat": "#1f77b4", "tool": "#d62728", "work": "#2ca02c"}
    defs = "".join(
        f'<marker id="arrow-{c[1:]}" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" markerHeight="7" '
        f'orient="auto-start-reverse"><path d="M 0 0 L 10 5 L 0 10 z" fill="{c}"/></marker>'
        for c in colours.values())
    home_z, plat_half = 2.55, 0.7  # the default platform's home height
    tip = (0.15, 0.35)
    work = (2.6, 1.2, math.radians(20))
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" '
             f'font-family="sans-serif">', f"<defs>{defs}</defs>",
             f'<rect width="{W}" height="{H}" fill="white"/>']
    # the base, the legs, the platform, the tool
    bx0, bz0 = px(-0.8, 0.0)
    bx1, _ = px(0.8, 0.0)
    parts.append(f'<rect x="{bx0:.1f}" y="{bz0:.1f}" width="{bx1 - bx0:.1f}" height="10" fill="#bbbbbb"/>')
    for xb, xp in ((-0.7, -0.35), (0.7, 0.35), (-0.3, -0.65), (0.3, 0.65)):
        x0, z0 = px(xb, 0.0)
        x1, z1 = px(xp, home_z)
        parts.append(f'<line x1="{x0:.1f}" y1="{z0:.1f}" x2="{x1:.1f}" y2="{z1:.1f}" stroke="#999999" '
                     f'stroke-width="6"/>')
    px0, pz0 = px(-plat_half, home_z)
    px1, _ = px(plat_half, home_z)
    parts.append(f'<rect x="{px0:.1f}" y="{pz0 - 6:.1f}" width="{px1 - px0:.1f}" height="12" fill="#9ecae1"/>')
    tx0, tz0 = px(0.0, home_z)
    tx1, tz1 = px(tip[0], home_z + tip[1])
    parts.append(f'<line x1="{tx0:.1f}" y1="{tz0:.1f}" x2="{tx1:.1f}" y2="{tz1:.1f}" stroke="#d62728" '
                 f'stroke-width="5" stroke-dasharray="2 0"/>')
    # the work surface, tilted
    wx, wz, wp = work
    sx0, sz0 = px(wx - 0.9 * math.cos(wp), wz + 0.9 * math.sin(wp))
    sx1, sz1 = px(wx + 0.9 * math.cos(wp), wz - 0.9 * math.sin(wp))
    parts.append(f'<line x1="{sx0:.1f}" y1="{sz0:.1f}" x2="{sx1:.1f}" y2="{sz1:.1f}" stroke="#98df8a" '
                 f'stroke-width="10"/>')
    parts += axes(0.0, 0.0, 0.0, "o (base)", colours["base"])
    parts += axes(0.0, home_z, 0.0, "o' (platform)", colours["plat"], 0.4)
    parts += axes(tip[0], home_z + tip[1], 0.0, "T (tool: pivot)", colours["tool"], 0.3)
    parts += axes(wx, wz, wp, "W (work)", colours["work"])
    # the offsets
    notes = [
        ((400.0, 40.0), colours["tool"], "T in o': offset t, rotation R_T (a tool frame)"),
        ((400.0, 60.0), colours["work"], "W in the base: origin w, rotation R_W (a work frame)"),
        ((400.0, 90.0), "#333333", "commanded and reported: the pose X of T in W"),
        ((400.0, 110.0), "#333333", "R_P = R_W R_X R_T^T,  p = w + R_W x - R_P t"),
    ]
    for (x, y), c, text in notes:
        parts.append(f'<text x="{x:.1f}" y="{y:.1f}" fill="{c}" font-size="13">{text}</text>')
    parts.append("</svg>")
    return "\n".join(parts) + "\n"


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print("usage: draw_frames.py OUT.svg", file=sys.stderr)
        return 2
    Path(argv[0]).write_text(svg())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
