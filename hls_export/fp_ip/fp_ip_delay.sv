// fp_ip_delay: a DEPTH-stage shift register (DEPTH >= 0; 0 is a wire) for the Floating-Point Operator
// stand-ins (fp_ip_standin.sv), which pad the rtl/fp operators' latency with it up to the IP's C_LATENCY.
//
// INIT is the power-up value of every stage (a variable initializer, not a reset: there is no reset). The
// stand-in's valid line uses INIT = 0, like the Xilinx core without aresetn, whose flops start at 0 after
// configuration.
// Latency: DEPTH cycles of clk (the stand-in's gated clock, so disabled cycles do not count).
`default_nettype none

module fp_ip_delay #(
    parameter int              WIDTH = 1,
    parameter int              DEPTH = 1,
    parameter logic [WIDTH-1:0] INIT = '0
) (
    /* verilator lint_off UNUSEDSIGNAL */
    input  wire logic             clk,   // unused when DEPTH = 0 (a wire)
    /* verilator lint_on UNUSEDSIGNAL */
    input  wire logic [WIDTH-1:0] d,
    output logic      [WIDTH-1:0] q
);
    if (DEPTH == 0) begin : g_wire
        assign q = d;
    end else begin : g_stages
        // The initializer is the power-up value of the flops (the core has no reset port), and the always_ff
        // below is their only writer: what PROCASSINIT warns about (an initial value mixed with a process
        // that writes the variable) is exactly the FPGA behaviour modelled here.
        /* verilator lint_off PROCASSINIT */
        logic [WIDTH-1:0] stage_q [DEPTH] = '{default: INIT};
        /* verilator lint_on PROCASSINIT */

        always_ff @(posedge clk) begin
            stage_q[0] <= d;
            for (int i = 1; i < DEPTH; i++) stage_q[i] <= stage_q[i-1];
        end

        assign q = stage_q[DEPTH-1];
    end
endmodule

`default_nettype wire
