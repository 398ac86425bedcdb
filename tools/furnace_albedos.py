"""Print Mitsuba 3's white-furnace albedos of its rough lobes, which
tests/test_glossy.cpp (Glossy.WhiteFurnacesMatchMitsuba) compares spm's
with: the mean sampling weight of roughconductor (material "none": eta 0,
k 1, reflects everything) and roughdielectric carrying photons
(TransportMode::Importance), alpha 0.1, Beckmann and GGX, at incidence
angles from the normal (past 90: from inside), with standard errors.

    build/venv-mitsuba/bin/python tools/furnace_albedos.py
"""
import math

import drjit as dr
import mitsuba as mi

SAMPLES = 4_000_000


def albedo(bsdf, mode, theta_deg):
    si = dr.zeros(mi.SurfaceInteraction3f)
    t = math.radians(theta_deg)
    si.wi = mi.Vector3f(math.sin(t), 0.0, math.cos(t))
    si.n = mi.Normal3f(0.0, 0.0, 1.0)
    si.sh_frame = mi.Frame3f(si.n)
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(0, SAMPLES)
    _, w = bsdf.sample(mi.BSDFContext(mode), si, sampler.next_1d(), sampler.next_2d())
    mean = dr.mean(w.x)
    error = dr.sqrt((dr.mean(w.x * w.x) - mean * mean) / SAMPLES)
    return float(mean[0]), float(error[0])


def main():
    mi.set_variant("llvm_ad_rgb")
    for distribution in ("beckmann", "ggx"):
        for kind, angles, mode in (("roughconductor", (0, 30, 60), mi.TransportMode.Radiance),
                                   ("roughdielectric", (0, 30, 60, 150), mi.TransportMode.Importance)):
            d = {"type": kind, "distribution": distribution, "alpha": 0.1}
            if kind == "roughconductor":
                d["material"] = "none"
            bsdf = mi.load_dict(d)
            for theta in angles:
                mean, error = albedo(bsdf, mode, theta)
                print("%-9s %-16s %4d  %.6f  %.1e" % (distribution, kind, theta, mean, error))


if __name__ == "__main__":
    main()
