// fp_ip_clock_gate: simulation model of an integrated clock-gating cell (ICG), for the Floating-Point
// Operator stand-ins (fp_ip_standin.sv).
//
// The Xilinx Floating-Point Operator freezes completely while its clock enable `aclken` is 0. The rtl/fp
// operators it is replaced with have no clock enable, so the stand-in clocks them (and its own delay lines)
// with gclk = clk & en_q, where en_q is `en` captured by a latch that is transparent while clk is low (the
// classic latch-based ICG): en may change at any time while clk is high (it comes from flops on clk in the HLS
// wrappers) without glitching gclk, and a rising edge of clk with en = 1 is a rising edge of gclk in the same
// time step, so flops on gclk sample the same values as flops on clk would. Simulation only: an FPGA build
// uses the Xilinx core itself, or clock enables.
// Latency: none (combinational apart from the latch).
`default_nettype none

module fp_ip_clock_gate (
    input  wire logic clk,
    input  wire logic en,
    output logic      gclk
);
    logic en_q;   // en, latched while clk is low

    always_latch begin
        if (!clk) en_q = en;
    end

    assign gclk = clk & en_q;
endmodule

`default_nettype wire
