# run_hls.tcl: Vitis HLS synthesis of the PGS kernel (hls_export/pgs_kernel.cpp) and export of its Verilog into
# hls_export/verilog/. `make hls` runs it when vitis_hls is on PATH:
#
#     vitis_hls -f hls_export/run_hls.tcl
#
# Target: xczu9eg-ffvb1156-2-e (ZCU102) at 275 MHz (the thesis's fp32 clock). The project goes to build/hls/.
# Environment (all optional):
#   PGS_MAX_BODIES, PGS_MAX_MANIFOLDS   table sizes (defaults 65536 and 262144, as the RTL; see README.md for
#                                        what fits the device's BRAM)
#   PGS_CONS_W, PGS_BODY_IN_W, PGS_BODY_OUT_W   stream beat widths (512, 128, 128)
#   PGS_IINV_W                           inverse-inertia words per body (3; 1 scalar, 6 the symmetric 3x3)
#   PGS_MU_W                             friction-coefficient words per friction record (0; 1 per manifold)
#   PGS_IMPULSES_IN_RECORDS              1 (default): the records design, the RTL's IMPULSES_IN_RECORDS (impulses
#                                        in the records, m_axis_imp out, no impulse array); 0: impulses on chip
#                                        (the old design). Its C simulation needs the thread-safe local
#                                        stream shims (-DPGS_FORCE_SHIMS, added to the csim flags below).
#   PGS_SOFT_CONTACT                     0 (default); 1: Box2D's soft contact row (the RTL's SOFT_CONTACT)
#   PGS_TANGENTS_ON_CHIP                 0 (default); 1: friction records without t0, t1, derived from the normal
#                                        (the RTL's TANGENTS_ON_CHIP; only with PGS_IMPULSES_IN_RECORDS = 1)
#   PGS_WINDOW, PGS_WINDOW_CTX, PGS_LANES  0, 8, 1 (default: the streaming kernel); PGS_WINDOW = N (a power of two):
#                                        the window kernel with a ring of N records of PGS_LANES (1, 2, 4) slots,
#                                        up to PGS_WINDOW_CTX passes per fetch (the RTL's WINDOW, WINDOW_CTX, LANES;
#                                        only with PGS_IMPULSES_IN_RECORDS = 1)
#   PGS_CSIM_DIR                         a run directory written by sim.drive.harness_run.write_inputs for a job of
#                                        the same design (the records design: with impulse_plan.bin): run the
#                                        C simulation testbench on it first (csim_design)
#   PGS_HLS_STEPS                        "csynth export" by default; add "cosim" for Vitis's own C/RTL
#                                        co-simulation (needs PGS_CSIM_DIR)
# Written without access to Vitis HLS: untested (hls_export/README.md).

set here [file dirname [file normalize [info script]]]
set root [file dirname $here]
set part xczu9eg-ffvb1156-2-e
set clock_mhz 275

proc env_or {name default} {
    if {[info exists ::env($name)] && $::env($name) ne ""} { return $::env($name) }
    return $default
}

set defines [list]
foreach {name default} {PGS_MAX_BODIES 65536 PGS_MAX_MANIFOLDS 262144 PGS_CONS_W 512 PGS_BODY_IN_W 128
                        PGS_BODY_OUT_W 128 PGS_IINV_W 3 PGS_MU_W 0 PGS_IMPULSES_IN_RECORDS 1
                        PGS_SOFT_CONTACT 0 PGS_TANGENTS_ON_CHIP 0 PGS_WINDOW 0 PGS_WINDOW_CTX 8 PGS_LANES 1} {
    lappend defines "-D$name=[env_or $name $default]"
}
# the golden operation order: nothing fused, no fast-math reassociation
set cflags "-I$here -ffp-contract=off [join $defines { }]"
# the records design's testbench plays the DMA in a second thread on the blocking local streams (C simulation only)
set csimflags [expr {[env_or PGS_IMPULSES_IN_RECORDS 1] ? "-DPGS_FORCE_SHIMS -pthread" : ""}]
set steps [env_or PGS_HLS_STEPS "csynth export"]

file mkdir [file join $root build hls]
cd [file join $root build hls]
open_project -reset pgs_kernel
set_top pgs_kernel
add_files [file join $here pgs_kernel.cpp] -cflags $cflags -csimflags $csimflags
add_files -tb [file join $here pgs_csim_main.cpp] -cflags "$cflags $csimflags"
open_solution -reset solution1 -flow_target vivado
set_part $part
create_clock -period [format %.3f [expr {1000.0 / $clock_mhz}]] -name default
config_export -format ip_catalog -rtl verilog

set csim_dir [env_or PGS_CSIM_DIR ""]
if {$csim_dir ne ""} {
    # the testbench's command line is the Verilator harness's: DIR SEED GAP BP MAX_CYCLES
    csim_design -argv "[file normalize $csim_dir] 1 0 0 0"
}
if {[lsearch $steps csynth] >= 0} {
    csynth_design
}
if {[lsearch $steps cosim] >= 0 && $csim_dir ne ""} {
    cosim_design -rtl verilog -argv "[file normalize $csim_dir] 1 0 0 0"
}
if {[lsearch $steps export] >= 0} {
    export_design -rtl verilog -format ip_catalog
    set out [file join $here verilog]
    file delete -force $out
    file mkdir $out
    foreach f [glob -nocomplain [file join [pwd] pgs_kernel solution1 syn verilog *]] {
        file copy -force $f $out
    }
    puts "run_hls.tcl: Verilog exported to $out"
}
exit
