"""Write scenes/textures/sky.exr: a small synthetic lat-long sky (64 x 32,
linear RGB) for the environment-map scenes and tests: a blue gradient from
the horizon to the zenith, a dim brown ground below the horizon, and a sun,
a disk of 6 degrees whose radiance is 2,000 times the sky's, at 35 degrees
elevation. The map's frame is Mitsuba's: u = atan2(x, -z) / 2 pi across,
theta = acos(y) down.

    build/venv-mitsuba/bin/python tools/make_sky.py
"""
import math
import os

import mitsuba as mi

W, H = 64, 32
SUN_ELEVATION, SUN_AZIMUTH, SUN_RADIUS = 35.0, 0.3, 6.0


def direction(u, v):
    phi, theta = 2.0 * math.pi * u, math.pi * v
    return (math.sin(phi) * math.sin(theta), math.cos(theta), -math.cos(phi) * math.sin(theta))


def main():
    mi.set_variant("scalar_rgb")
    e = math.radians(SUN_ELEVATION)
    sun = direction(SUN_AZIMUTH, 0.5 - e / math.pi)
    pixels = []
    for j in range(H):
        for i in range(W):
            # Texel (i, j) as envmap's lookup places it: u at the texel's
            # centre, theta = j pi / (H - 1).
            d = direction((i + 0.5) / W, j / (H - 1))
            if d[1] >= 0.0:
                t = d[1]
                rgb = [0.6 + 0.2 * t, 0.75 + 0.15 * t, 1.0]
                rgb = [c * (1.0 - 0.5 * t) for c in rgb]
            else:
                rgb = [0.12, 0.09, 0.06]
            cos_sun = sum(a * b for a, b in zip(d, sun))
            if cos_sun > math.cos(math.radians(SUN_RADIUS)):
                rgb = [2000.0 * 0.6, 2000.0 * 0.55, 2000.0 * 0.45]
            pixels.extend(rgb)
    bitmap = mi.Bitmap(mi.TensorXf(pixels, shape=(H, W, 3)), mi.Bitmap.PixelFormat.RGB)
    out = os.path.join(os.path.dirname(__file__), "..", "scenes", "textures", "sky.exr")
    bitmap.write(os.path.normpath(out))


if __name__ == "__main__":
    main()
