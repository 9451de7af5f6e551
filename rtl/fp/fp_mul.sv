// fp_mul: pipelined floating-point multiplier (y = a * b).
//
// Arithmetic contract (models/formats/number_format.py): subnormal inputs read as signed zero; the exact
// product is rounded to nearest, ties to even, at MAN_BITS+1 bits with an unbounded exponent; a
// rounded result below the smallest normal flushes to a zero with the sign of the product;
// overflow gives +-inf. The result sign is always sign(a) XOR sign(b).
// Exceptions handled:
//   * NaN operand, or 0 * inf / inf * 0  -> canonical quiet NaN
//   * inf * non-zero                     -> +-inf
//   * 0 * finite (incl. flushed subnormals) -> +-0
//   * overflow -> +-inf, result below min normal after rounding -> +-0
// Event flags (models/formats/number_format.py, registered with y): flags = {invalid, underflow, overflow};
//   overflow / underflow: the rounding overflowed to +-inf / flushed a non-zero result to +-0 (from
//   fp_result_stage), invalid: a NaN made from non-NaN operands (0 * inf).
// Latency: LATENCY = 3 cycles, one operation accepted per cycle (II = 1).
//   stage 1: unpack, classify, sign and exponent sum
//   stage 2: significand product (maps to a pipelined DSP multiplier)
//   stage 3: 1-bit normalization, round to nearest even, exceptions, pack (output register)
// Only the valid bits are reset; each data register stage is enabled by the valid bit of the stage
// before it.
`default_nettype none

module fp_mul #(
    parameter  int EXP_BITS = 8,
    parameter  int MAN_BITS = 23,
    localparam int W        = 1 + EXP_BITS + MAN_BITS,
    localparam int LATENCY  = 3
) (
    input  wire logic         clk,
    input  wire logic         rst,        // synchronous, active high; clears the valid pipeline
    input  wire logic         in_valid,
    input  wire logic [W-1:0] a,
    input  wire logic [W-1:0] b,
    output logic              out_valid,
    output logic [W-1:0]      y,
    output logic [2:0]        flags       // {invalid, underflow, overflow}, with y
);
    localparam int P    = MAN_BITS + 1;
    localparam int EW   = EXP_BITS + 2;      // holds ea + eb - bias + 1 (signed)
    localparam int BIAS = (1 << (EXP_BITS - 1)) - 1;

    // ---------------- stage 1: unpack ----------------
    // Each register stage takes an operation only when the stage before holds one (stage_valid, a
    // clock enable on a board): its logic, the operands' unpack included, is written inside that
    // branch with the branch's own temporaries, so a simulator computes it only then.
    /* verilator lint_off UNUSEDSIGNAL */
    logic [LATENCY:0] stage_valid;   // [i]: in_valid i cycles ago; the stages enabled here read [1]
    /* verilator lint_on UNUSEDSIGNAL */

    // The exception side band (fp_result_stage's `special`) and the exponent sum travel to stage 3.
    logic [P-1:0]         s1_a_sig, s1_b_sig;
    logic [4:0]           s1_special, s2_special;
    logic signed [EW-1:0] s1_exp, s2_exp;

    always_ff @(posedge clk) begin
        if (in_valid) begin : b_unpack
            automatic logic                a_sign, b_sign, a_zero, b_zero, a_inf, b_inf, a_nan, b_nan;
            automatic logic [EXP_BITS-1:0] a_exp, b_exp;
            // the fields as fp_unpack gives them: a subnormal reads as a zero
            {a_sign, a_exp} = a[W-1:MAN_BITS];
            {b_sign, b_exp} = b[W-1:MAN_BITS];
            a_zero = (a_exp == '0);
            b_zero = (b_exp == '0);
            a_inf  = (a_exp == '1) && (a[MAN_BITS-1:0] == '0);
            b_inf  = (b_exp == '1) && (b[MAN_BITS-1:0] == '0);
            a_nan  = (a_exp == '1) && (a[MAN_BITS-1:0] != '0);
            b_nan  = (b_exp == '1) && (b[MAN_BITS-1:0] != '0);
            s1_a_sig   <= a_zero ? '0 : {1'b1, a[MAN_BITS-1:0]};
            s1_b_sig   <= b_zero ? '0 : {1'b1, b[MAN_BITS-1:0]};
            s1_special <= {a_nan || b_nan, (a_inf && b_zero) || (a_zero && b_inf), a_inf || b_inf,
                           a_zero || b_zero, a_sign ^ b_sign};
            s1_exp     <= $signed({2'b00, a_exp}) + $signed({2'b00, b_exp}) - EW'(BIAS);
        end
    end

    // ---------------- stage 2: multiply ----------------
    logic [2*P-1:0] s2_prod;

    always_ff @(posedge clk) begin
        if (stage_valid[1]) begin
            s2_prod    <= {{P{1'b0}}, s1_a_sig} * {{P{1'b0}}, s1_b_sig};
            s2_special <= s1_special;
            s2_exp     <= s1_exp;
        end
    end

    // ---------------- stage 3: normalize, round, pack ----------------
    // The product of two significands in [1, 2) lies in [1, 4): bit 2P-1 tells which binade.
    logic                 hi;
    logic [P-1:0]         sig_n;
    logic                 rnd_n, sticky_n;
    logic signed [EW-1:0] exp_n;

    always_comb begin
        hi       = s2_prod[2*P-1];
        sig_n    = hi ? s2_prod[2*P-1:P] : s2_prod[2*P-2:P-1];
        rnd_n    = hi ? s2_prod[P-1] : s2_prod[P-2];
        // the bits below the round bit: the low P-2 in both binades, and bit P-2 in the upper one
        sticky_n = (|s2_prod[P-3:0]) || (hi && s2_prod[P-2]);
        exp_n = s2_exp + {{(EW-1){1'b0}}, hi};
    end

    fp_result_stage #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .EW(EW), .LATENCY(LATENCY)) u_result (
        .clk(clk), .rst(rst), .in_valid(in_valid), .special(s2_special),
        .exp_in(exp_n), .sig_in(sig_n), .round_bit(rnd_n), .sticky(sticky_n),
        .stage_valid(stage_valid), .out_valid(out_valid), .y(y), .flags(flags));
endmodule

`default_nettype wire
