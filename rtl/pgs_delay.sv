// pgs_delay: a tapped delay line (shift register) for the generated datapaths (rtl/gen).
//
// d is delayed through DEPTH register stages (DEPTH >= 0; 0 is a plain wire). N_TAPS outputs read
// the line at any stage: tap k (q[k*WIDTH +: WIDTH]) is d delayed by TAPS[k*32 +: 32] cycles,
// 0 <= TAPS[k] <= DEPTH. One line serves every consumer of a value, so a value used at several
// pipeline stages costs max(delay) registers, not the sum. Data registers are not reset (no valid
// is carried here). Exceptions: none. Latency: per tap, TAPS[k] cycles.
`default_nettype none

module pgs_delay #(
    parameter int                   WIDTH  = 1,
    parameter int                   DEPTH  = 1,
    parameter int                   N_TAPS = 1,
    parameter logic [N_TAPS*32-1:0] TAPS   = (N_TAPS * 32)'(DEPTH)
) (
    // clk has no load when DEPTH == 0 (the line is a wire).
    /* verilator lint_off UNUSEDSIGNAL */
    input  wire logic                    clk,
    /* verilator lint_on UNUSEDSIGNAL */
    input  wire logic [WIDTH-1:0]        d,
    output logic      [N_TAPS*WIDTH-1:0] q
);
    logic [WIDTH-1:0] stage [0:DEPTH];   // stage[i]: d delayed by i cycles

    assign stage[0] = d;

    for (genvar i = 1; i <= DEPTH; i++) begin : g_stage
        always_ff @(posedge clk) stage[i] <= stage[i-1];
    end

    for (genvar k = 0; k < N_TAPS; k++) begin : g_tap
        localparam int D = int'(TAPS[k*32 +: 32]);
        if (D < 0 || D > DEPTH) begin : g_bad_tap
            $error("pgs_delay: tap %0d = %0d outside 0..DEPTH (%0d)", k, D, DEPTH);
        end
        assign q[k*WIDTH +: WIDTH] = stage[D];
    end
endmodule

`default_nettype wire
