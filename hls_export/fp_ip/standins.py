"""Stand-ins for the Xilinx Floating-Point Operator cores of a Vitis HLS export, for Verilator.

A Vitis HLS export (``hls_export/verilog/``, from ``make hls``) wraps every floating-point operator in a module
such as ``pgs_kernel_fadd_32ns_32ns_32_13_full_dsp_1`` that instantiates the Xilinx Floating-Point Operator as
``pgs_kernel_fadd_32ns_32ns_32_13_full_dsp_1_ip``. That ``_ip`` module is encrypted Xilinx IP: Verilator cannot
use it. :func:`write_standins` finds every ``_ip`` module the export instantiates and writes, per name, one thin
SystemVerilog module of that name (``<name>.sv``, in a folder of its own) with the ports the export connects,
instantiating :file:`fp_ip_standin.sv` with the operation, format and ``C_LATENCY`` of that core. Compile the
export without its own ``*_ip.v`` files, plus these wrappers, :func:`standin_sources` and ``rtl/fp/*.sv``.

Where the facts come from (regular expressions, case-insensitive; ``\\w`` = letters, digits, ``_``):

* instances, in every ``*.v`` / ``*.sv`` file of the export: :data:`INSTANCE_RE`, a statement
  ``<module>_ip [#(...)] <instance> ( ... );`` at the start of a line, and its named port connections
  ``.<port> ( ... )`` (:data:`PORT_RE`);
* the core's configuration, first from a Tcl script (``*.tcl``) that creates it (the ``<name>_ip.tcl`` Vitis HLS
  writes: ``create_ip -name floating_point ... -module_name <name>`` followed by ``set_property -dict [list
  CONFIG.c_latency 11 ...]``): :data:`TCL_CREATE_RE` finds the ``create_ip`` of that module name (its text runs
  to the next ``create_ip``), :data:`TCL_CONFIG_RE` reads ``CONFIG.<key> <value>`` / ``CONFIG.<key> {<value>}``;
  keys ``c_latency``, ``operation_type`` (``Add_Subtract`` with ``add_sub_value`` ``Add`` / ``Subtract``,
  ``Multiply``, ``Divide``, ``Square_root``, ``Compare``), ``c_a_exponent_width`` / ``c_a_fraction_width``
  (the fraction width counts the hidden bit) or ``a_precision_type`` (``Single``, ``Half``);
* else from a Verilog file that defines ``module <name>`` (the ``<name>_ip.v`` of the IP, which instantiates
  ``floating_point_v7_1_<n> #(.C_LATENCY(11), .C_HAS_ADD(1), ...)``): :data:`MODULE_RE` finds the module up to
  ``endmodule``, :data:`VERILOG_GENERIC_RE` reads ``.C_<KEY>(<value>)``; keys ``C_LATENCY``, ``C_HAS_ADD``,
  ``C_HAS_SUBTRACT``, ``C_HAS_MULTIPLY``, ``C_HAS_DIVIDE``, ``C_HAS_SQRT``, ``C_HAS_COMPARE`` (the one set to 1),
  ``C_A_WIDTH`` and ``C_A_FRACTION_WIDTH``;
* operation and format not found there: from the wrapper name (:data:`NAME_OP_RE`: ``_<p><op>_`` with ``p`` =
  ``f`` binary32, ``h`` binary16, and ``op`` one of add, sub, mul, div, sqrt, cmp). The latency is never taken
  from the name (its stage count includes the wrapper's own registers, and the rule changed between versions):
  no ``C_LATENCY`` in a ``.tcl`` or ``.v`` is an error.

Anything else (another operation, ``add_sub_value Both``, a port other than ``aclk``, ``aclken``,
``s_axis_{a,b,operation}_tvalid/tdata``, ``m_axis_result_tvalid/tdata``) raises :class:`StandinError`. A core
whose ``C_LATENCY`` is shorter than the rtl/fp operator's (add/sub 4, mul 3, div ``MAN_BITS + 5``, sqrt ``MAN_BITS
+ 4``, cmp 1; e.g. a compare with latency 0) gets its wrapper all the same: its elaboration stops with the
stand-in's error message. Command line: ``python -m hls_export.fp_ip.standins EXPORT_DIR OUT_DIR``.
"""

from __future__ import annotations

import argparse
import re
from dataclasses import dataclass, field
from pathlib import Path

FP_IP_DIR = Path(__file__).resolve().parent

#: ``<module>_ip [#(...)] <instance> ( <ports> );`` at the start of a line
INSTANCE_RE = re.compile(
    r"^[ \t]*(?P<module>\w+_ip)\s+(?:#\s*\((?:[^()]|\([^()]*\))*\)\s*)?(?P<inst>\w+)\s*\((?P<ports>.*?)\)\s*;",
    re.MULTILINE | re.DOTALL)
#: a named port connection ``.<port> (``
PORT_RE = re.compile(r"\.\s*(?P<port>\w+)\s*\(")
#: ``create_ip ... -module_name <name>``
TCL_CREATE_RE = re.compile(r"create_ip\b[^\n]*?-module_name\s+\{?(?P<name>\w+)\}?", re.IGNORECASE)
#: ``CONFIG.<key> <value>`` or ``CONFIG.<key> {<value>}``
TCL_CONFIG_RE = re.compile(r"CONFIG\.(?P<key>\w+)\s+(?:\{(?P<braced>[^}]*)\}|(?P<bare>[^\s\\\]]+))", re.IGNORECASE)
#: ``module <name> ... endmodule``
MODULE_RE = r"^[ \t]*module\s+{name}\b(?P<body>.*?)^[ \t]*endmodule\b"
#: ``.C_<KEY>(<value>)`` in a parameter list
VERILOG_GENERIC_RE = re.compile(r"\.\s*(?P<key>C_\w+)\s*\(\s*\"?(?P<value>[^)\"]*?)\"?\s*\)", re.IGNORECASE)
#: ``_<precision letter><operation>_`` in a wrapper name
NAME_OP_RE = re.compile(r"_(?P<prec>[fhd])(?P<op>add|sub|mul|div|sqrt|cmp)_", re.IGNORECASE)

PORTS_IN = ("aclk", "aclken", "s_axis_a_tvalid", "s_axis_a_tdata", "s_axis_b_tvalid", "s_axis_b_tdata",
            "s_axis_operation_tvalid", "s_axis_operation_tdata")
PORTS_OUT = ("m_axis_result_tvalid", "m_axis_result_tdata")
#: what an input the export leaves out is tied to (a core without aclken runs every cycle)
TIE_OFF = {"aclk": "1'b0", "aclken": "1'b1", "s_axis_a_tvalid": "1'b1", "s_axis_a_tdata": "'0",
           "s_axis_b_tvalid": "1'b1", "s_axis_b_tdata": "'0", "s_axis_operation_tvalid": "1'b1",
           "s_axis_operation_tdata": "8'h00"}
TCL_OPERATIONS = {"multiply": "mul", "divide": "div", "square_root": "sqrt", "compare": "cmp"}
TCL_ADD_SUB = {"add": "add", "subtract": "sub"}
VERILOG_OPERATIONS = {"C_HAS_ADD": "add", "C_HAS_SUBTRACT": "sub", "C_HAS_MULTIPLY": "mul", "C_HAS_DIVIDE": "div",
                      "C_HAS_SQRT": "sqrt", "C_HAS_COMPARE": "cmp"}
PRECISIONS = {"single": (8, 23), "half": (5, 10)}      # (EXP_BITS, MAN_BITS)
NAME_PRECISIONS = {"f": (8, 23), "h": (5, 10), "d": (11, 52)}


class StandinError(ValueError):
    """The export instantiates an ``_ip`` core the stand-ins cannot replace, or its configuration is missing."""


@dataclass
class IpCore:
    """One ``_ip`` module of an export, as the stand-in wrapper needs it."""

    name: str
    operation: str
    c_latency: int
    exp_bits: int
    man_bits: int
    ports: list[str]                     # the ports the export connects, in the stand-in's order
    sources: list[str] = field(default_factory=list)   # the export files the facts came from

    @property
    def width(self) -> int:
        return 1 + self.exp_bits + self.man_bits

    @property
    def tdata_width(self) -> int:
        return 8 * ((self.width + 7) // 8)


def standin_sources() -> list[Path]:
    """The SystemVerilog of the parameterized stand-in (compile with ``rtl/fp/*.sv``)."""
    return sorted(FP_IP_DIR.glob("*.sv"))


def _tcl_config(text: str, name: str) -> dict[str, str] | None:
    """The ``CONFIG.*`` properties (lower-case keys) set after ``create_ip ... -module_name name``, if any."""
    creates = list(TCL_CREATE_RE.finditer(text))
    for k, m in enumerate(creates):
        if m.group("name") == name:
            end = creates[k + 1].start() if k + 1 < len(creates) else len(text)
            return {c.group("key").lower(): (c.group("braced") if c.group("braced") is not None else c.group("bare"))
                    for c in TCL_CONFIG_RE.finditer(text, m.end(), end)}
    return None


def _verilog_config(text: str, name: str) -> dict[str, str] | None:
    """The ``.C_*(...)`` generics (upper-case keys) inside ``module name ... endmodule``, if it has any."""
    m = re.search(MODULE_RE.format(name=re.escape(name)), text, re.MULTILINE | re.DOTALL)
    if m is None:
        return None
    generics = {g.group("key").upper(): g.group("value").strip() for g in VERILOG_GENERIC_RE.finditer(m.group("body"))}
    return generics or None


def _from_tcl(cfg: dict[str, str], name: str) -> tuple[str | None, int | None, tuple[int, int] | None]:
    op_type = cfg.get("operation_type", "").lower()
    op = None
    if op_type == "add_subtract":
        op = TCL_ADD_SUB.get(cfg.get("add_sub_value", "").lower())
        if op is None:
            raise StandinError(f"{name}: add_sub_value {cfg.get('add_sub_value')!r} (only Add or Subtract)")
    elif op_type:
        op = TCL_OPERATIONS.get(op_type)
        if op is None:
            raise StandinError(f"{name}: operation_type {cfg['operation_type']} has no stand-in")
    latency = int(cfg["c_latency"]) if "c_latency" in cfg else None
    fmt = None
    if "c_a_exponent_width" in cfg and "c_a_fraction_width" in cfg:
        fmt = (int(cfg["c_a_exponent_width"]), int(cfg["c_a_fraction_width"]) - 1)
    elif cfg.get("a_precision_type", "").lower() in PRECISIONS:
        fmt = PRECISIONS[cfg["a_precision_type"].lower()]
    return op, latency, fmt


def _from_verilog(cfg: dict[str, str], name: str) -> tuple[str | None, int | None, tuple[int, int] | None]:
    ops = [op for key, op in VERILOG_OPERATIONS.items() if cfg.get(key, "0") not in ("0", "")]
    if len(ops) > 1:
        raise StandinError(f"{name}: several operations enabled ({', '.join(ops)})")
    latency = int(cfg["C_LATENCY"]) if "C_LATENCY" in cfg else None
    fmt = None
    if "C_A_WIDTH" in cfg and "C_A_FRACTION_WIDTH" in cfg:
        width, frac = int(cfg["C_A_WIDTH"]), int(cfg["C_A_FRACTION_WIDTH"])
        fmt = (width - frac, frac - 1)
    return (ops[0] if ops else None), latency, fmt


def find_ip_cores(export_dir: Path | str) -> list[IpCore]:
    """Every ``_ip`` module instantiated in ``export_dir``'s Verilog, with its configuration (sorted by name)."""
    export_dir = Path(export_dir)
    hdl = {p: p.read_text(errors="replace") for p in sorted(export_dir.rglob("*")) if p.suffix in (".v", ".sv")}
    tcl = {p: p.read_text(errors="replace") for p in sorted(export_dir.rglob("*.tcl"))}
    ports: dict[str, list[str]] = {}
    for path, text in hdl.items():
        for m in INSTANCE_RE.finditer(text):
            found = [p.group("port") for p in PORT_RE.finditer(m.group("ports"))]
            unknown = sorted(set(found) - set(PORTS_IN) - set(PORTS_OUT))
            if unknown:
                raise StandinError(f"{m.group('module')} (in {path.name}): ports {', '.join(unknown)} have no stand-in")
            ports.setdefault(m.group("module"), [])
            ports[m.group("module")] = [p for p in PORTS_IN + PORTS_OUT if p in found or p in ports[m.group("module")]]
    cores = []
    for name in sorted(ports):
        op = latency = fmt = None
        sources: list[str] = []
        for path, text in tcl.items():
            cfg = _tcl_config(text, name)
            if cfg is not None:
                op, latency, fmt = _from_tcl(cfg, name)
                sources.append(path.name)
                break
        if latency is None:
            for path, text in hdl.items():
                cfg = _verilog_config(text, name)
                if cfg is not None:
                    v_op, latency, v_fmt = _from_verilog(cfg, name)
                    op, fmt = op or v_op, fmt or v_fmt
                    sources.append(path.name)
                    break
        if latency is None:
            raise StandinError(f"{name}: no C_LATENCY in a .tcl (CONFIG.c_latency) or .v (.C_LATENCY(...)) "
                               "of the export")
        by_name = NAME_OP_RE.search(name)
        if op is None and by_name:
            op = by_name.group("op").lower()
        if fmt is None and by_name:
            fmt = NAME_PRECISIONS[by_name.group("prec").lower()]
        if op is None or fmt is None:
            raise StandinError(f"{name}: operation or format not found in the export")
        if op == "cmp" and "s_axis_operation_tdata" not in ports[name]:
            raise StandinError(f"{name}: a compare without s_axis_operation_tdata (fixed predicate) has no stand-in")
        cores.append(IpCore(name, op, latency, fmt[0], fmt[1], ports[name], sources))
    return cores


def wrapper_text(core: IpCore) -> str:
    """The SystemVerilog of the stand-in wrapper for one core (module ``core.name``)."""
    widths = {"s_axis_a_tdata": core.tdata_width, "s_axis_b_tdata": core.tdata_width, "s_axis_operation_tdata": 8,
              "m_axis_result_tdata": 8 if core.operation == "cmp" else core.tdata_width}
    decl = []
    for p in core.ports:
        rng = f"[{widths[p] - 1}:0] " if p in widths else ""
        decl.append(f"    {'input  wire logic' if p in PORTS_IN else 'output logic     '} {rng}{p}")
    conns = [f".{p}({p if p in core.ports else TIE_OFF[p]})" for p in PORTS_IN]
    unused = [p for p in PORTS_OUT if p not in core.ports]
    conns += [f".{p}({p if p in core.ports else 'unused_' + p})" for p in PORTS_OUT]
    lines = [
        f"// {core.name}:",
        "// Stand-in (for simulation) of the Xilinx Floating-Point Operator core of this name in a Vitis HLS export,",
        f"// generated by hls_export/fp_ip/standins.py from {', '.join(core.sources)}: fp_ip_standin with",
        f"// OPERATION {core.operation}, C_LATENCY {core.c_latency}, EXP_BITS {core.exp_bits}, "
        f"MAN_BITS {core.man_bits}. Do not edit.",
        "`default_nettype none",
        "",
        f"module {core.name} (",
        ",\n".join(decl),
        ");",
    ]
    for p in unused:
        width = widths.get(p, 1)
        lines += ["    // an output the export leaves unconnected",
                  "    /* verilator lint_off UNUSEDSIGNAL */",
                  f"    logic {f'[{width - 1}:0] ' if width > 1 else ''}unused_{p};",
                  "    /* verilator lint_on UNUSEDSIGNAL */"]
    lines += [
        f"    fp_ip_standin #(.OPERATION(\"{core.operation}\"), .EXP_BITS({core.exp_bits}), "
        f".MAN_BITS({core.man_bits}), .C_LATENCY({core.c_latency})) u_standin (",
        "        " + ",\n        ".join(conns),
        "    );",
        "endmodule",
        "",
        "`default_nettype wire",
        "",
    ]
    return "\n".join(lines)


def write_standins(export_dir: Path | str, out_dir: Path | str) -> list[Path]:
    """Write one ``<name>.sv`` stand-in wrapper per ``_ip`` core of the export into ``out_dir``; return the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for core in find_ip_cores(export_dir):
        path = out / f"{core.name}.sv"
        path.write_text(wrapper_text(core))
        paths.append(path)
    return paths


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hls_export.fp_ip.standins", description=__doc__.splitlines()[0])
    ap.add_argument("export_dir", type=Path, help="the exported Verilog (e.g. hls_export/verilog)")
    ap.add_argument("out_dir", type=Path, help="where to write the <name>_ip.sv stand-in wrappers")
    args = ap.parse_args(argv)
    for core, path in zip(find_ip_cores(args.export_dir), write_standins(args.export_dir, args.out_dir)):
        print(f"{path}: {core.operation} C_LATENCY {core.c_latency} E{core.exp_bits}M{core.man_bits}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
