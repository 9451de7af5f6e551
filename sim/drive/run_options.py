"""The options ``make sim`` and ``make sweep`` share, and what they name: the kernel format, the kernel design
(the window kernel's ring, lanes and passes per fetch, the body beats, where the impulses live, who derives the
tangents), the job on that design, and the frame to run (a scene's, captured or cached, or a saved frame file).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from models import scenes
from models.formats.frame import Frame, load
from models.formats.number_format import NumberFormat, parse_format
from models.kernel.kernel_job import KernelJob


def hardware_format(name: str) -> NumberFormat:
    """A number format the kernel can be built for (``parse_format`` also knows float64, the reference)."""
    fmt = parse_format(name)
    if not isinstance(fmt, NumberFormat):
        raise ValueError(f"number format {name!r} is the float64 reference, not a kernel format (fp32, fp16, bf16 "
                         "or eXmY)")
    return fmt


def add_kernel_args(ap: argparse.ArgumentParser) -> None:
    """The kernel options shared by ``make sim`` and ``make sweep``: ring, passes per fetch, lanes, body beats."""
    ap.add_argument("--record-window", type=int, default=0,
                    help="0: the streaming kernel; N (a power of two): the window kernel with a ring of N records "
                         "(rtl/pgs_window.sv)")
    ap.add_argument("--fetch-passes", type=int, default=0,
                    help="window kernel: passes per fetch of the records (0: as many as the ring holds)")
    ap.add_argument("--lanes", type=int, default=1,
                    help="window kernel: manifolds issued per cycle (a power of two; LANES build parameter)")
    ap.add_argument("--body-bits", type=int, default=128,
                    help="beat width of the body-in and body-out streams (128, 256 or 512)")
    ap.add_argument("--shared-datapath", type=int, choices=(0, 1), default=None,
                    help="1: one datapath per lane for the contact and the friction passes (SHARED_DATAPATH build "
                         "parameter, every design's default); 0: a contact and a friction pipe per lane (the default "
                         "with --datapath xls, whose pipes XLS compiles)")
    ap.add_argument("--add-dsp", type=int, choices=(0, 1), default=0,
                    help="1: every fp_add of the pipes in its DSP48E2 form (ADD_SHIFT_DSP build parameter: the same "
                         "results and cycles, the fit's DSP figures); 0: in LUTs and carry chains (the default)")
    ap.add_argument("--inertia", choices=("build", "scene"), default="build",
                    help="the body record's inverse-inertia words: the default build's (3, or 6 for the full matrix), "
                         "or as few as the scene needs (1 where every dynamic body is isotropic: IINV_W = 1, two "
                         "words fewer per body in the body stream and on chip)")
    ap.add_argument("--impulse-store", choices=("onchip", "records"), default="onchip",
                    help="accumulated impulses in the on-chip RAM, or travelling with the records through DDR "
                         "(IMPULSES_IN_RECORDS build parameter; the window kernel: each fetch of one pass kind, an "
                         "impulse ring as deep as the record ring)")


def kernel_label(args: argparse.Namespace) -> str:
    """The kernel options in a run's name: empty for the streaming kernel with 128-bit body streams and the
    hand-scheduled pipes."""
    return ((f"-ring{args.record_window}" if args.record_window else "")
            + (f"-lanes{args.lanes}" if args.lanes > 1 else "")
            + (f"-body{args.body_bits}" if args.body_bits != 128 else "")
            + ("-impulses-in-records" if getattr(args, "impulse_store", "onchip") == "records" else "")
            + ("-tangents-on-chip" if getattr(args, "tangents", "host") == "chip" else "")
            + ("" if getattr(args, "shared_datapath", 1) else "-two-pipes")
            + ("-dsp-adders" if getattr(args, "add_dsp", 0) else "")
            + ("-scene-inertia" if getattr(args, "inertia", "build") == "scene" else "")
            + ("-xls" if getattr(args, "datapath", "rtl") == "xls" else ""))


def datapath_options(args: argparse.Namespace) -> dict[str, bool]:
    """The build options the command line fixes before the frame is read, by ``KernelBuild`` field: what
    ``sim.compile.kernel_build.check_datapath`` refuses early for a datapath that does not cover them (the frame's
    own, such as its inverse-inertia words, are checked when the build is made)."""
    return {"tangents_on_chip": getattr(args, "tangents", "host") == "chip",
            "shared_datapath": bool(getattr(args, "shared_datapath", 1)),
            "add_dsp": bool(getattr(args, "add_dsp", 0))}


def kernel_job(job: KernelJob, args: argparse.Namespace) -> KernelJob:
    """``job`` on the kernel the options name: the window kernel's plan with ``--record-window``, the impulses in
    the records with ``--impulse-store records``, the tangent basis derived on chip with ``--tangents chip``, a
    contact and a friction pipe per lane with ``--shared-datapath 0``, the DSP48E2 adders with ``--add-dsp 1``, the
    scene's inverse-inertia words with ``--inertia scene``."""
    job = job.with_datapath(bool(getattr(args, "shared_datapath", 1))).with_adders(bool(getattr(args, "add_dsp", 0)))
    job = job.with_inertia(getattr(args, "inertia", "build") == "scene")
    if getattr(args, "tangents", "host") == "chip":
        if args.record_window:
            raise ValueError("--tangents chip is a configuration of the streaming kernel (no --record-window)")
        job = job.tangents_derived()
    if getattr(args, "impulse_store", "onchip") == "records":
        job = job.impulses_travelling()
    if not args.record_window:
        return job
    return job.windowed(args.record_window, fetch_passes=args.fetch_passes or None, lanes=args.lanes)


def check_kernel_args(args: argparse.Namespace) -> None:
    """The kernel options shared by ``make sim`` and ``make sweep``: ring, lanes, passes per fetch, body beats; an
    unset ``--shared-datapath`` becomes its default (0 with the XLS datapath, else 1)."""
    if args.shared_datapath is None:
        args.shared_datapath = 0 if getattr(args, "datapath", "rtl") == "xls" else 1
    if args.record_window and (args.record_window < 2 or args.record_window & (args.record_window - 1)):
        raise ValueError(f"--record-window must be 0 or a power of two >= 2, got {args.record_window}")
    if args.lanes < 1 or args.lanes & (args.lanes - 1) or (args.lanes > 1 and not args.record_window):
        raise ValueError(f"--lanes must be a power of two, and above 1 only with --record-window, got {args.lanes}")
    if args.body_bits not in (128, 256, 512):
        raise ValueError(f"--body-bits must be 128, 256 or 512, got {args.body_bits}")
    if not 0 <= args.fetch_passes <= 8:
        raise ValueError(f"--fetch-passes must be in 0..8, got {args.fetch_passes}")


def load_frame(args: argparse.Namespace) -> tuple[Frame, str]:
    """The frame to run (``--frame`` or the scene's, captured or cached) and the name of the runs made of it."""
    if args.frame:
        return load(args.frame), Path(args.frame).stem
    return scenes.load_scene(args.scene, args.scene_args, args.seed)
