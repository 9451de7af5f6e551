// coverage_hook: writes Verilator's coverage counters when the simulation ends (make coverage, sim/coverage/).
// Bound into the top (pgs_kernel, fp_ops_tb) of a --coverage build only, by the bind file sim/coverage/build.py
// generates; the compiled harness calls the model's final() after the run, which runs this final block: no change
// to the harness or the RTL. Output file: $PGS_COVERAGE_FILE
// (default coverage.dat), written by coverage_hook.cpp.
module pgs_coverage_hook;
    import "DPI-C" function void pgs_coverage_write();
    final pgs_coverage_write();
endmodule

