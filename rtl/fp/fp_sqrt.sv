// fp_sqrt: fully pipelined, correctly rounded floating-point square root (y = sqrt(a)).
//
// Algorithm: restoring radix-2 digit-by-digit square root, one root bit per pipeline stage.
// The significand (doubled when the unbiased exponent is odd, so the exponent halves exactly) is
// scaled to the 2P+2 bit integer N = M' * 2^(P+1) (P = MAN_BITS+1); the recurrence produces the
// P+1 bit root R = floor(sqrt(N)) in [2^P, 2^(P+1)) and the remainder N - R^2. R's top P bits are
// the significand, its LSB the round bit, and remainder != 0 the sticky bit (round to nearest even;
// an exact tie cannot occur for a square root, the rounding is the shared RNE logic anyway).
// Arithmetic contract (models/formats/number_format.py): subnormal inputs read as signed zero. The result
// of a normal input is always normal (no overflow or underflow is possible).
// Exceptions handled:
//   * NaN, -inf, any negative non-zero number -> canonical quiet NaN
//   * +-0 (and +-subnormal, flushed)           -> +-0 (sqrt(-0) = -0)
//   * +inf                                     -> +inf
// Event flags (models/formats/number_format.py, registered with y): flags = {invalid, underflow, overflow};
//   overflow / underflow: the rounding overflowed to +-inf / flushed a non-zero result to +-0 (from
//   fp_result_stage), invalid: a NaN made from non-NaN operands (a negative non-zero operand, -inf included; overflow and underflow
//   cannot happen).
// Latency: LATENCY = MAN_BITS + 4 cycles (binary32: 27, binary16: 14, bfloat16: 11), II = 1.
//   stage 1           : unpack, classify, exponent halving, radicand alignment
//   stages 2 .. P+2   : one root bit each (P+1 = MAN_BITS+2 stages)
//   stage  P+3        : round to nearest even, exceptions, pack (output register)
// Only the valid bits are reset; each data register stage is enabled by the valid bit of the stage
// before it (the side band's shift register is free-running).
`default_nettype none

module fp_sqrt #(
    parameter  int EXP_BITS = 8,
    parameter  int MAN_BITS = 23,
    localparam int W        = 1 + EXP_BITS + MAN_BITS,
    localparam int LATENCY  = MAN_BITS + 4
) (
    input  wire logic         clk,
    input  wire logic         rst,        // synchronous, active high; clears the valid pipeline
    input  wire logic         in_valid,
    input  wire logic [W-1:0] a,
    output logic              out_valid,
    output logic [W-1:0]      y,
    output logic [2:0]        flags       // {invalid, underflow, overflow}, with y
);
    localparam int P    = MAN_BITS + 1;
    localparam int NR   = P + 1;             // root bits = recurrence stages
    localparam int RW   = P + 4;             // remainder width (remainder <= 2 * root < 2^(P+2))
    localparam int EW   = EXP_BITS + 2;
    localparam int BIAS = (1 << (EXP_BITS - 1)) - 1;

    // ---------------- stage 1: unpack ----------------
    logic                a_sign, a_zero, a_inf, a_nan;
    logic [EXP_BITS-1:0] a_exp;
    logic [P-1:0]        a_sig;

    fp_unpack #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_unpack_a (
        .x(a), .sign(a_sign), .exp(a_exp), .sig(a_sig), .is_zero(a_zero), .is_inf(a_inf), .is_nan(a_nan)
    );

    logic                odd;        // unbiased exponent odd (bias is odd: biased exponent even)
    logic [EXP_BITS-1:0] exp_half;   // (a_exp + bias - odd) / 2: biased result exponent
    logic [P:0]          m_scaled;   // M' = M or 2M

    always_comb begin
        odd      = !a_exp[0];
        // a_exp + bias - odd is even; halving it term by term (bias is odd):
        exp_half = (a_exp >> 1) + EXP_BITS'(BIAS >> 1) + {{(EXP_BITS-1){1'b0}}, a_exp[0]};
        m_scaled = odd ? {a_sig, 1'b0} : {1'b0, a_sig};
    end

    // The exception side band (fp_result_stage's `special`) and the halved exponent travel to the
    // last stage.
    logic                invalid;
    logic [4:0]          special;
    logic [4:0]          last_special;
    logic [EXP_BITS-1:0] last_exp;

    always_comb begin
        invalid = a_sign && !a_zero && !a_nan;
        special = {a_nan, invalid, a_inf, a_zero, a_sign};
    end

    fp_data_pipe #(.WIDTH(5 + EXP_BITS), .DEPTH(NR + 1)) u_side (
        .clk(clk), .d({special, exp_half}), .q({last_special, last_exp})
    );

    // Per-stage registers of the recurrence; index 0 is stage 1, index k holds the state after k
    // root bits.
    logic [P:0]    st_rad  [NR+1];   // radicand bits still to bring down (MSB first)
    logic [RW-1:0] st_rem  [NR+1];   // partial remainder
    logic [NR-1:0] st_root [NR+1];   // root bits so far (LSB = newest)

    /* verilator lint_off UNUSEDSIGNAL */
    logic [LATENCY:0] stage_valid;   // [i]: in_valid i cycles ago; the recurrence reads [NR:1]
    /* verilator lint_on UNUSEDSIGNAL */

    // Each stage takes an operation only when the stage before holds one (a clock enable on a board;
    // blocking temporaries inside the branch, so a simulator computes the stage only then).
    always_ff @(posedge clk) begin
        if (in_valid) begin
            st_rad[0]  <= m_scaled;
            st_rem[0]  <= '0;
            st_root[0] <= '0;
        end
    end

    // ---------------- stages 2 .. NR+1: restoring recurrence ----------------
    // N = M' * 2^(P+1) has 2P+2 bits: M' (P+1 bits) followed by P+1 zeros; each stage brings down
    // two bits, the shift register supplies M' and then zeros.
    always_ff @(posedge clk) begin
        for (int k = 0; k < NR; k++) begin
            if (stage_valid[k+1]) begin : b_digit
                automatic logic [RW-1:0] cur, trial;
                automatic logic          rbit;
                cur   = {st_rem[k][RW-3:0], st_rad[k][P:P-1]};
                trial = {{(RW-NR-2){1'b0}}, st_root[k], 2'b01};
                rbit  = (cur >= trial);
                st_rad[k+1]  <= {st_rad[k][P-2:0], 2'b00};
                st_rem[k+1]  <= rbit ? (cur - trial) : cur;
                st_root[k+1] <= {st_root[k][NR-2:0], rbit};
            end
        end
    end

    // ---------------- last stage: round, pack ----------------
    fp_result_stage #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .EW(EW), .LATENCY(LATENCY)) u_result (
        .clk(clk), .rst(rst), .in_valid(in_valid), .special(last_special),
        .exp_in($signed({2'b00, last_exp})), .sig_in(st_root[NR][NR-1:1]), .round_bit(st_root[NR][0]),
        .sticky(st_rem[NR] != '0), .stage_valid(stage_valid), .out_valid(out_valid), .y(y), .flags(flags));
endmodule

`default_nettype wire
