// pgs_delay: a tapped delay line for the generated datapaths (rtl/gen).
//
// d is delayed by up to DEPTH clock cycles (DEPTH >= 0; 0 is a plain wire). N_TAPS outputs read
// the line at any delay: tap k (q[k*WIDTH +: WIDTH]) is d delayed by TAPS[k*32 +: 32] cycles,
// 0 <= TAPS[k] <= DEPTH. One line serves every consumer of a value, so a value used at several
// pipeline stages costs max(delay) storage, not the sum. Data storage is not reset.
//
// valid[i] says whether the word d had i cycles ago must be kept (in a generated pipe: the pipe's
// valid bit i cycles after this value's ready cycle). A stage, a RAM write and a tap register take
// a word only when it is valid (a clock or write enable on a board; a skipped copy in simulation),
// so tap k shows d of TAPS[k] cycles ago whenever that word was valid (valid[TAPS[k]] is 1), and
// an older word otherwise. Exceptions: none. Latency: per tap, TAPS[k] cycles.
//
// Storage: a line with DEPTH < RAM_MIN_DEPTH is a shift register. A longer line is a circular
// buffer: a RAM of DEPTH words written at a free-running pointer every cycle, and per tap of delay
// D >= 2 a registered read of the word written D - 1 cycles before (the read address never equals
// the write address, so any simple dual-port RAM holds it; a tap of delay 1 is a register, of
// delay 0 a wire). Per cycle this writes one word and one register per tap instead of moving every
// stage, and it is how a board build keeps long delays in block or distributed RAM. Both forms
// give the same q in every cycle where the tap's word was valid, once the line has been full
// (before that the words are unset).
//
// Mapping on a board: the RAM form's array carries ram_style = "block" when BLOCK_MIN_DEPTH > 0 and
// DEPTH >= BLOCK_MIN_DEPTH, else "distributed" (LUT RAM). Block RAM takes a long line's LUTs away at
// one RAMB18/36 per tap of delay >= 2 (each tap is one read port; the registered read is the block
// RAM's output latch); which lines go there is a kernel build parameter (the generated pipes'
// DELAY_BLOCK_MIN_DEPTH), counted the same way by sim/fit/resource_model.py. Simulation is the same for
// every value: the attribute only tells synthesis where the array lives.
`default_nettype none

module pgs_delay #(
    parameter int                   WIDTH         = 1,
    parameter int                   DEPTH         = 1,
    parameter int                   N_TAPS        = 1,
    parameter logic [N_TAPS*32-1:0] TAPS          = (N_TAPS * 32)'(DEPTH),
    parameter int                   RAM_MIN_DEPTH = 4,  // lines at least this deep are circular buffers
    parameter int                   BLOCK_MIN_DEPTH = 0,  // RAM lines at least this deep in block RAM; 0: none
    localparam int                  VW            = DEPTH > 0 ? DEPTH : 1
) (
    // clk has no load when DEPTH == 0 (the line is a wire).
    /* verilator lint_off UNUSEDSIGNAL */
    input  wire logic                    clk,
    /* verilator lint_on UNUSEDSIGNAL */
    input  wire logic [WIDTH-1:0]        d,
    // valid[i]: d of i cycles ago is kept; the RAM form reads valid[0] and its taps' bits only, a
    // line of depth 0 (a wire) none
    /* verilator lint_off UNUSEDSIGNAL */
    input  wire logic [VW-1:0]           valid,
    /* verilator lint_on UNUSEDSIGNAL */
    output logic      [N_TAPS*WIDTH-1:0] q
);
    for (genvar k = 0; k < N_TAPS; k++) begin : g_check
        localparam int D = int'(TAPS[k*32 +: 32]);
        if (D < 0 || D > DEPTH) begin : g_bad_tap
            $error("pgs_delay: tap %0d = %0d outside 0..DEPTH (%0d)", k, D, DEPTH);
        end
    end
    if (RAM_MIN_DEPTH < 2) begin : g_bad_min_depth
        $error("pgs_delay: RAM_MIN_DEPTH = %0d, must be >= 2", RAM_MIN_DEPTH);
    end
    if (BLOCK_MIN_DEPTH < 0) begin : g_bad_block_depth
        $error("pgs_delay: BLOCK_MIN_DEPTH = %0d, must be >= 0", BLOCK_MIN_DEPTH);
    end

    if (DEPTH == 0) begin : g_wire
        for (genvar k = 0; k < N_TAPS; k++) begin : g_tap
            assign q[k*WIDTH +: WIDTH] = d;
        end
    end else if (DEPTH < RAM_MIN_DEPTH) begin : g_shift
        logic [WIDTH-1:0] stage [1:DEPTH];   // stage[i]: d delayed by i cycles

        // one process for the whole line (a simulator updates it in one step, not one per stage)
        always_ff @(posedge clk) begin
            if (valid[0]) stage[1] <= d;
            for (int i = 2; i <= DEPTH; i++) begin
                if (valid[i-1]) stage[i] <= stage[i-1];
            end
        end
        for (genvar k = 0; k < N_TAPS; k++) begin : g_tap
            localparam int D = int'(TAPS[k*32 +: 32]);
            if (D == 0) begin : g_d
                assign q[k*WIDTH +: WIDTH] = d;
            end else begin : g_stage
                assign q[k*WIDTH +: WIDTH] = stage[D];
            end
        end
    end else begin : g_ram
        localparam int    AW        = $clog2(DEPTH);
        // read by synthesis only: Verilator ignores the attribute that names it
        /* verilator lint_off UNUSEDPARAM */
        localparam string RAM_STYLE = BLOCK_MIN_DEPTH > 0 && DEPTH >= BLOCK_MIN_DEPTH ? "block" : "distributed";
        /* verilator lint_on UNUSEDPARAM */

        (* ram_style = RAM_STYLE *)
        logic [WIDTH-1:0] mem [0:DEPTH-1];   // mem[(wr_ptr - i) mod DEPTH]: d delayed by i cycles, 1 <= i <= DEPTH
        logic [AW-1:0]    wr_ptr;            // free-running; no reset port: a power-up value (FPGA register init)

        initial wr_ptr = '0;   // 4-state simulators would otherwise keep an X pointer for ever
        always_ff @(posedge clk) begin
            if (valid[0]) mem[wr_ptr] <= d;
            wr_ptr <= wr_ptr >= AW'(DEPTH - 1) ? '0 : wr_ptr + AW'(1);
        end

        for (genvar k = 0; k < N_TAPS; k++) begin : g_tap
            localparam int D = int'(TAPS[k*32 +: 32]);
            if (D == 0) begin : g_wire
                assign q[k*WIDTH +: WIDTH] = d;
            end else if (D == 1) begin : g_reg
                logic [WIDTH-1:0] r;
                always_ff @(posedge clk) if (valid[0]) r <= d;
                assign q[k*WIDTH +: WIDTH] = r;
            end else begin : g_read
                // the word written D - 1 cycles ago, read at this edge: D cycles old after it
                localparam int BACK = D - 1;   // 1 .. DEPTH - 1
                logic [WIDTH-1:0] r;
                always_ff @(posedge clk) begin
                    if (valid[BACK]) begin : b_read   // the word written BACK cycles ago was valid
                        automatic logic [AW-1:0] rd_ptr;
                        rd_ptr = wr_ptr >= AW'(BACK) ? wr_ptr - AW'(BACK) : wr_ptr + AW'(DEPTH - BACK);
                        r <= mem[rd_ptr];
                    end
                end
                assign q[k*WIDTH +: WIDTH] = r;
            end
        end
    end
endmodule

`default_nettype wire
