#!/usr/bin/env python3
"""Render a reference image of an spm scene with Mitsuba 3's volpath.

The project's scenes are Mitsuba 3 XML (docs/SCENES.md), so Mitsuba
3 is the independent judge of what spm renders. This script

  1. makes a virtual environment under the build directory
     (BUILD/venv-mitsuba) with Mitsuba 3 from PyPI, pinned, and re-runs itself
     inside it (nothing is installed system-wide);
  2. replaces the scene's <integrator> (spm's own) with
     <integrator type="volpath"> (max_depth, rr_depth), keeping every other
     byte and every line number of the file, so Mitsuba's messages name the
     original file's lines;
  3. applies the scene's $ default overrides (-D name=value);
  4. renders with the llvm_ad_rgb variant when Dr.Jit's LLVM backend runs here
     (it needs a system libLLVM recent enough for the code it generates:
     Debian 12's libllvm19, which tools/install-deps.sh installs and
     DRJIT_LIBLLVM_PATH is pointed at unless already set; with the
     libllvm15 that pocl-opencl-icd pulls in, scenes with spheres abort),
     else scalar_rgb;
  5. writes a 32-bit float RGB OpenEXR and a JSON record beside it (command,
     Mitsuba version, variant, spp, wall time, SHA-256 of the EXR).

Idempotent: when OUT.json says the same scene (by SHA-256), overrides and
settings made OUT.exr and the EXR's SHA-256 still matches, nothing is
rendered again (--force renders anyway).

Examples:
  tools/reference.py scenes/cornell_fog.xml -o build/ref/cornell_fog.exr \\
      -D res=64 --spp 4096
  tools/reference.py scenes/cornell_fog.xml -o /tmp/t.exr -D res=64 --time 10
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
MITSUBA_REQUIREMENT = "mitsuba==3.9.1"
# Packages the validation tools need inside the venv (compare.py and
# convergence.py use numpy and matplotlib).
VENV_REQUIREMENTS = [MITSUBA_REQUIREMENT, "numpy", "matplotlib"]
VENV_NAME = "venv-mitsuba"


# --------------------------------------------------------------------------
# The virtual environment


def venv_dir(build_dir: Path) -> Path:
    return Path(build_dir).resolve() / VENV_NAME


def in_venv(venv: Path) -> bool:
    return Path(sys.prefix).resolve() == venv.resolve()


def ensure_venv(build_dir: Path, requirements=VENV_REQUIREMENTS, quiet=False) -> Path:
    """Creates BUILD/venv-mitsuba with `requirements` unless a marker file says
    it already has exactly those. Returns the venv's python."""
    venv = venv_dir(build_dir)
    python = venv / "bin" / "python"
    marker = venv / ".spm-requirements"
    wanted = "\n".join(requirements) + "\n"
    if python.exists() and marker.exists() and marker.read_text() == wanted:
        return python
    log = (lambda *a: None) if quiet else (lambda *a: print("reference:", *a, file=sys.stderr))
    if not python.exists():
        log(f"creating the virtual environment {venv}")
        try:
            subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
        except subprocess.CalledProcessError:
            sys.exit("reference: 'python3 -m venv' failed; on Debian install python3-venv "
                     "(apt-get install python3-venv)")
    log("installing " + " ".join(requirements) + " from PyPI")
    subprocess.run([str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
                    *requirements], check=True)
    marker.write_text(wanted)
    return python


def select_libllvm() -> None:
    """Points DRJIT_LIBLLVM_PATH at the newest system libLLVM-N.so, N >= 16,
    unless the caller chose one. Dr.Jit otherwise loads plain libLLVM.so,
    which on Debian 12 is LLVM 15: it cannot select the fminimum that
    Mitsuba's sphere and bounding-box code emits, and the render aborts, so
    the judge falls back to the much slower scalar_rgb."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return
    found = []
    for d in ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib"):
        for f in Path(d).glob("libLLVM-*.so") if Path(d).is_dir() else []:
            m = re.fullmatch(r"libLLVM-(\d+)\.so", f.name)
            if m and int(m.group(1)) >= 16:
                found.append((int(m.group(1)), str(f)))
    if found:
        os.environ["DRJIT_LIBLLVM_PATH"] = max(found)[1]


def reexec_in_venv(script: str) -> None:
    """Runs `script` again with the venv's python (under --build-dir) unless
    this is it or only help was asked for, which needs no venv."""
    if "-h" in sys.argv or "--help" in sys.argv:
        return
    select_libllvm()
    build_dir = pre_parse_build_dir(sys.argv[1:])
    venv = venv_dir(build_dir)
    if in_venv(venv):
        return
    python = ensure_venv(build_dir)
    os.execv(str(python), [str(python), script, *sys.argv[1:]])


def default_build_dir() -> Path:
    return REPO / "build"


def pre_parse_build_dir(argv) -> Path:
    """--build-dir before argparse runs (the venv must exist before the tools
    import numpy or mitsuba)."""
    for i, a in enumerate(argv):
        if a == "--build-dir" and i + 1 < len(argv):
            return Path(argv[i + 1])
        if a.startswith("--build-dir="):
            return Path(a.split("=", 1)[1])
    return default_build_dir()


# --------------------------------------------------------------------------
# Scene rewriting


def _mask_comments(text: str) -> str:
    """The text with every XML comment's characters replaced by spaces
    (newlines kept), so that offsets stay valid and commented-out elements
    are not matched."""
    return re.sub(r"<!--.*?-->", lambda m: re.sub(r"[^\n]", " ", m.group(0)), text, flags=re.S)


def volpath_integrator(max_depth: int, rr_depth: int) -> str:
    return (f'<integrator type="volpath"><integer name="max_depth" value="{max_depth}"/>'
            f'<integer name="rr_depth" value="{rr_depth}"/></integrator>')


def substitute_integrator(text: str, max_depth: int, rr_depth: int) -> str:
    """Replaces the scene's top-level <integrator> element with volpath, padded
    with the newlines it had so later line numbers do not move. A scene with
    no integrator gets one after its <scene> tag."""
    masked = _mask_comments(text)
    pattern = re.compile(r"<integrator\b[^>]*?/>|<integrator\b[^>]*>.*?</integrator\s*>", re.S)
    found = list(pattern.finditer(masked))
    new = volpath_integrator(max_depth, rr_depth)
    if len(found) > 1:
        raise SystemExit(f"reference: the scene has {len(found)} <integrator> elements; expected at most one")
    if not found:
        m = re.search(r"<scene\b[^>]*>", masked)
        if not m:
            raise SystemExit("reference: no <scene> element")
        return text[:m.end()] + new + text[m.end():]
    m = found[0]
    return text[:m.start()] + new + "\n" * text[m.start():m.end()].count("\n") + text[m.end():]


def scene_defaults(text: str) -> dict:
    masked = _mask_comments(text)
    out = {}
    for m in re.finditer(r"<default\b([^>]*)/?>", masked):
        attrs = dict(re.findall(r'(\w+)\s*=\s*"([^"]*)"', m.group(1)))
        if "name" in attrs:
            out[attrs["name"]] = attrs.get("value", "")
    return out


def parse_defines(items) -> dict:
    out = {}
    for d in items or []:
        if "=" not in d or d.startswith("="):
            raise SystemExit(f"reference: -D expects name=value, got '{d}'")
        k, v = d.split("=", 1)
        out[k] = v
    return out


def sha256_file(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


# --------------------------------------------------------------------------
# Mitsuba


_PROBE = r"""
import json, sys
import mitsuba as mi
import drjit as dr
mi.set_variant("llvm_ad_rgb")
print("LLVM %d.%d.%d" % dr.detail.llvm_version(), flush=True)
mi.file_resolver().prepend(sys.argv[1])
scene = mi.load_string(sys.stdin.read(), **json.loads(sys.argv[2]))
img = mi.render(scene, spp=1)
dr.eval(img)
"""


def pick_variant(requested: str, scene_path: Path, text: str, defines: dict, log) -> str:
    """`auto`: llvm_ad_rgb when a one-sample render of this very scene runs in a
    child process (Dr.Jit needs a system libLLVM, and an LLVM too old for the
    code it generates aborts the whole process: LLVM 15 stops with 'Cannot
    select: fminimum'), else scalar_rgb."""
    import mitsuba as mi
    if requested != "auto":
        mi.set_variant(requested)
        return requested
    probe = subprocess.run([sys.executable, "-c", _PROBE, str(scene_path.resolve().parent), json.dumps(defines)],
                           input=text, capture_output=True, text=True)
    if probe.returncode == 0:
        mi.set_variant("llvm_ad_rgb")
        return "llvm_ad_rgb"
    lines = [l for l in (probe.stdout + probe.stderr).splitlines() if l.strip() and not l.startswith(" ")]
    log("llvm_ad_rgb does not run here (" + " / ".join(lines[:3])[:300] + "); using scalar_rgb. "
        "Dr.Jit needs a system libLLVM recent enough for its code: Debian's libllvm19 works "
        "(DRJIT_LIBLLVM_PATH selects one)")
    mi.set_variant("scalar_rgb")
    return "scalar_rgb"


def load_scene(scene_path: Path, text: str, defines: dict):
    import mitsuba as mi
    fr = mi.file_resolver()
    fr.prepend(str(scene_path.resolve().parent))
    return mi.load_string(text, **defines)


def render(scene, spp: int, seed: int, chunk_spp: int, time_budget: float, log, overhead: float = 0.0,
           first_chunk: int = 0):
    """Renders `spp` samples per pixel in chunks of at most `chunk_spp` (each
    an independent mi.render with its own seed) and averages them; with a
    time budget, renders chunks until the budget is spent: a chunk that would
    overrun it is halved until it fits, its time predicted from the last
    chunk's as `overhead` (seconds per launch) plus a time per sample, so
    that the budget's tail is not left unused. Chunks are numbered from
    `first_chunk` (a resumed reference's next one). Returns (image as
    float32 HxWx3 numpy array, spp rendered, render seconds)."""
    import mitsuba as mi
    import numpy as np
    acc = None
    done = 0
    chunks = first_chunk
    start = time.perf_counter()
    last = 0.0
    last_n = 1
    while True:
        if time_budget > 0:
            elapsed = time.perf_counter() - start
            n = chunk_spp
            if done > 0:
                per_spp = max(0.0, last - overhead) / last_n
                while n > 1 and elapsed + overhead + per_spp * n > time_budget:
                    n //= 2
                if elapsed + overhead + per_spp * n > time_budget:
                    break
        else:
            if done >= spp:
                break
            n = min(chunk_spp, spp - done)
        t0 = time.perf_counter()
        img = np.array(mi.render(scene, spp=n, seed=seed * 1000003 + chunks), dtype=np.float64)
        last = time.perf_counter() - t0
        last_n = n
        acc = img * n if acc is None else acc + img * n
        done += n
        chunks += 1
        if time_budget <= 0 and ((chunks - first_chunk) % 8 == 0 or done >= spp):
            log(f"{done}/{spp} spp, {time.perf_counter() - start:.1f} s")
    seconds = time.perf_counter() - start
    return (acc / done).astype(np.float32), done, seconds


def write_exr(path: Path, image) -> None:
    import mitsuba as mi
    import numpy as np
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.stem + ".tmp" + path.suffix)
    bmp = mi.Bitmap(np.ascontiguousarray(image, dtype=np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB)
    bmp.write(str(tmp))
    os.replace(tmp, path)


# --------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        description="Render a Mitsuba 3 volpath reference of an spm scene (the scene's <integrator> "
                    "replaced by volpath) to OpenEXR, with a JSON record beside it.",
        epilog="Examples:" + __doc__.split("Examples:")[1],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", type=Path, help="scene file (Mitsuba 3 XML)")
    p.add_argument("-o", "--output", type=Path, required=True, help="output OpenEXR (32-bit float RGB)")
    p.add_argument("-D", dest="defines", action="append", metavar="NAME=VALUE", default=[],
                   help="override a <default> of the scene (repeatable)")
    p.add_argument("--spp", type=int, default=0,
                   help="samples per pixel in all (default: the scene's sample_count)")
    p.add_argument("--time", type=float, default=0.0, metavar="SECONDS",
                   help="render chunks of --chunk-spp until this many seconds are spent, instead of --spp")
    p.add_argument("--chunk-spp", type=int, default=0,
                   help="samples per pixel per mi.render call (default: about 4M samples per call)")
    p.add_argument("--max-depth", type=int, default=64,
                   help="volpath max_depth (-1: unlimited; Russian roulette ends paths)")
    p.add_argument("--rr-depth", type=int, default=5, help="volpath rr_depth (Mitsuba's default 5)")
    p.add_argument("--seed", type=int, default=0, help="base seed (chunk i uses seed*1000003 + i)")
    p.add_argument("--variant", default="auto",
                   help="Mitsuba variant: auto (llvm_ad_rgb if it runs here, else scalar_rgb), or a name")
    p.add_argument("--build-dir", type=Path, default=default_build_dir(),
                   help="build directory holding venv-mitsuba (default: %(default)s)")
    p.add_argument("--json", type=Path, default=None,
                   help="metadata record (default: OUTPUT with .json)")
    p.add_argument("--force", action="store_true", help="render even when OUTPUT is up to date")
    p.add_argument("--resume", type=Path, default=None, metavar="EXR",
                   help="continue this reference (its JSON beside it: the same scene, defines, integrator, "
                        "seed and chunks) up to --spp: only the chunks it lacks are rendered, and the result "
                        "is the image a render of --spp from scratch gives")
    p.add_argument("--print-scene", action="store_true",
                   help="print the rewritten scene Mitsuba is given and exit")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    return p


def main() -> int:
    reexec_in_venv(os.path.abspath(__file__))
    args = build_parser().parse_args()
    log = (lambda *a: None) if args.quiet else (lambda *a: print("reference:", *a, file=sys.stderr, flush=True))

    scene_path = args.scene
    text = scene_path.read_text()
    defines = parse_defines(args.defines)
    declared = scene_defaults(text)
    unknown = sorted(set(defines) - set(declared))
    if unknown:
        raise SystemExit(f"reference: {scene_path}: no <default> named {', '.join(unknown)} "
                         f"(the scene declares: {', '.join(sorted(declared))})")
    rewritten = substitute_integrator(text, args.max_depth, args.rr_depth)
    if args.print_scene:
        sys.stdout.write(rewritten)
        return 0

    out = args.output
    meta_path = args.json or out.with_suffix(".json")
    request = {
        "scene": os.path.relpath(scene_path.resolve(), REPO),
        "scene_sha256": hashlib.sha256(text.encode()).hexdigest(),
        "defines": defines,
        "integrator": {"type": "volpath", "max_depth": args.max_depth, "rr_depth": args.rr_depth},
        "spp_requested": args.spp,
        "time_budget": args.time,
        "seed": args.seed,
        "variant_requested": args.variant,
        "mitsuba_requirement": MITSUBA_REQUIREMENT,
    }
    resumed = None
    if args.resume is not None:
        resumed = json.loads(args.resume.with_suffix(".json").read_text())
        same = {k: v for k, v in resumed["request"].items() if k != "spp_requested"}
        if same != {k: v for k, v in request.items() if k != "spp_requested"} or args.time > 0:
            raise SystemExit(f"reference: --resume {args.resume}: its record asks for another render "
                             f"(scene, defines, integrator, seed or a time budget differ)")
        if sha256_file(args.resume) != resumed["sha256"]:
            raise SystemExit(f"reference: --resume {args.resume}: the EXR does not match its record's SHA-256")
    if not args.force and out.exists() and meta_path.exists():
        try:
            old = json.loads(meta_path.read_text())
            if old.get("request") == request and old.get("sha256") == sha256_file(out):
                log(f"{out} is up to date ({meta_path}); --force renders it again")
                return 0
        except (ValueError, OSError):
            pass

    import mitsuba as mi
    variant = pick_variant(args.variant, scene_path, rewritten, defines, log)
    t_load = time.perf_counter()
    scene = load_scene(scene_path, rewritten, defines)
    load_seconds = time.perf_counter() - t_load
    sensor = scene.sensors()[0]
    size = [int(v) for v in sensor.film().size()]
    scene_spp = int(sensor.sampler().sample_count())
    spp = args.spp or scene_spp
    chunk = args.chunk_spp or max(1, min(spp if args.time <= 0 else 1 << 20, (1 << 22) // (size[0] * size[1])))
    log(f"{scene_path} with volpath (max_depth {args.max_depth}, rr_depth {args.rr_depth}) at "
        f"{size[0]}x{size[1]}, " + (f"{args.time} s" if args.time > 0 else f"{spp} spp") +
        f", variant {variant}, Mitsuba {mi.__version__}")
    if resumed is not None:
        if resumed["chunk_spp"] != chunk or resumed["spp"] % chunk or resumed["spp"] >= spp:
            raise SystemExit(f"reference: --resume {args.resume}: {resumed['spp']} spp in chunks of "
                             f"{resumed['chunk_spp']} cannot continue to {spp} in chunks of {chunk}")
        import numpy as np
        first = resumed["spp"] // chunk
        image, spp_done, seconds = render(scene, spp - resumed["spp"], args.seed, chunk, 0.0, log,
                                          first_chunk=first)
        old = np.array(mi.Bitmap(str(args.resume)), dtype=np.float64)[..., :3]
        image = ((old * resumed["spp"] + image.astype(np.float64) * spp_done) /
                 (resumed["spp"] + spp_done)).astype(np.float32)
        spp_done += resumed["spp"]
        seconds += resumed["render_seconds"]
    else:
        image, spp_done, seconds = render(scene, spp, args.seed, chunk, args.time, log)
    write_exr(out, image)
    digest = sha256_file(out)
    command = "tools/reference.py " + " ".join(
        os.path.relpath(a, REPO) if os.path.exists(a) and os.path.isabs(a) else a for a in sys.argv[1:])
    meta = {
        "request": request,
        "command": command,
        "output": os.path.relpath(out.resolve(), REPO),
        "mitsuba_version": mi.__version__,
        "variant": variant,
        "resolution": size,
        "spp": spp_done,
        "chunk_spp": chunk,
        "render_seconds": round(seconds, 3),
        "load_seconds": round(load_seconds, 3),
        "threads": os.cpu_count(),
        "llvm_version": (".".join(map(str, __import__("drjit").detail.llvm_version()))
                         if variant.startswith("llvm") else None),
        "sha256": digest,
        "mean_rgb": [float(image[..., c].mean()) for c in range(3)],
    }
    meta_path.write_text(json.dumps(meta, indent=2) + "\n")
    log(f"wrote {out} ({spp_done} spp in {seconds:.1f} s, sha256 {digest[:16]}...) and {meta_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
