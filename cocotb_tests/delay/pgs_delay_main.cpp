// pgs_delay_main.cpp: clocks cocotb_tests/delay/pgs_delay_tb.sv until it calls $finish ($fatal exits non-zero).
#include <memory>

#include "../../sim/harness/harness_driver.h"
#include "Vpgs_delay_tb.h"
#include "verilated.h"

int main(int argc, char** argv) {
    auto ctx = std::make_unique<VerilatedContext>();
    ctx->commandArgs(argc, argv);
    auto top = std::make_unique<Vpgs_delay_tb>(ctx.get(), "pgs_delay_tb");
    top->clk = 0;
    top->eval();
    for (unsigned cycle = 0; !ctx->gotFinish(); cycle++) {
        if (cycle > 50000) harness::fail("pgs_delay_main", "the testbench never finished");
        harness::clock_cycle(*top);
    }
    top->final();
    return 0;
}
