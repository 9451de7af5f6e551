// coverage_hook.cpp: the DPI function of coverage_hook.sv: write the coverage counters of the running model's
// context to $PGS_COVERAGE_FILE (default coverage.dat).
#include <cstdlib>

#include "verilated.h"
#include "verilated_cov.h"

extern "C" void pgs_coverage_write() {
    const char* path = std::getenv("PGS_COVERAGE_FILE");
    Verilated::threadContextp()->coveragep()->write(path && *path ? path : "coverage.dat");
}
