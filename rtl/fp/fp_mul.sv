// fp_mul: pipelined floating-point multiplier (y = a * b).
//
// Arithmetic contract (models/number_format.py): subnormal inputs read as signed zero; the exact
// product is rounded to nearest, ties to even, at MAN_BITS+1 bits with an unbounded exponent; a
// rounded result below the smallest normal flushes to a zero with the sign of the product;
// overflow gives +-inf. The result sign is always sign(a) XOR sign(b).
// Exceptions handled:
//   * NaN operand, or 0 * inf / inf * 0  -> canonical quiet NaN
//   * inf * non-zero                     -> +-inf
//   * 0 * finite (incl. flushed subnormals) -> +-0
//   * overflow -> +-inf, result below min normal after rounding -> +-0
// Event flags (models/number_format.py, registered with y): flags = {invalid, underflow, overflow};
//   overflow / underflow: the rounding overflowed to +-inf / flushed a non-zero result to +-0 (from
//   fp_round_pack), invalid: a NaN made from non-NaN operands (0 * inf).
// Latency: LATENCY = 3 cycles, one operation accepted per cycle (II = 1).
//   stage 1: unpack, classify, sign and exponent sum
//   stage 2: significand product (maps to a pipelined DSP multiplier)
//   stage 3: 1-bit normalization, round to nearest even, exceptions, pack (output register)
// Only the valid bits are reset; data registers are free-running.
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
    logic                a_sign, b_sign, a_zero, b_zero, a_inf, b_inf, a_nan, b_nan;
    logic [EXP_BITS-1:0] a_exp, b_exp;
    logic [P-1:0]        a_sig, b_sig;

    fp_unpack #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_unpack_a (
        .x(a), .sign(a_sign), .exp(a_exp), .sig(a_sig), .is_zero(a_zero), .is_inf(a_inf), .is_nan(a_nan)
    );
    fp_unpack #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_unpack_b (
        .x(b), .sign(b_sign), .exp(b_exp), .sig(b_sig), .is_zero(b_zero), .is_inf(b_inf), .is_nan(b_nan)
    );

    // The exception side band (fp_result_stage's `special`) and the exponent sum travel to stage 3.
    logic                 invalid;
    logic [4:0]           special;
    logic signed [EW-1:0] exp_sum;

    always_comb begin
        invalid = (a_inf && b_zero) || (a_zero && b_inf);
        special = {a_nan || b_nan, invalid, a_inf || b_inf, a_zero || b_zero, a_sign ^ b_sign};
        exp_sum = $signed({2'b00, a_exp}) + $signed({2'b00, b_exp}) - EW'(BIAS);
    end

    logic [4:0]           s2_special;
    logic signed [EW-1:0] s2_exp;

    fp_data_pipe #(.WIDTH(5 + EW), .DEPTH(2)) u_side (.clk(clk), .d({special, exp_sum}), .q({s2_special, s2_exp}));

    logic [P-1:0] s1_a_sig, s1_b_sig;

    always_ff @(posedge clk) begin
        s1_a_sig <= a_sig;
        s1_b_sig <= b_sig;
    end

    // ---------------- stage 2: multiply ----------------
    logic [2*P-1:0] s2_prod;

    always_ff @(posedge clk) begin
        s2_prod <= {{P{1'b0}}, s1_a_sig} * {{P{1'b0}}, s1_b_sig};
    end

    // ---------------- stage 3: normalize, round, pack ----------------
    // The product of two significands in [1, 2) lies in [1, 4): bit 2P-1 tells which binade.
    logic                 hi;
    logic [P-1:0]         sig_n;
    logic                 rnd_n, sticky_n;
    logic signed [EW-1:0] exp_n;

    always_comb begin
        hi = s2_prod[2*P-1];
        if (hi) begin
            sig_n    = s2_prod[2*P-1:P];
            rnd_n    = s2_prod[P-1];
            sticky_n = |s2_prod[P-2:0];
        end else begin
            sig_n    = s2_prod[2*P-2:P-1];
            rnd_n    = s2_prod[P-2];
            sticky_n = |s2_prod[P-3:0];
        end
        exp_n = s2_exp + {{(EW-1){1'b0}}, hi};
    end

    fp_result_stage #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .EW(EW), .LATENCY(LATENCY)) u_result (
        .clk(clk), .rst(rst), .in_valid(in_valid), .special(s2_special),
        .exp_in(exp_n), .sig_in(sig_n), .round_bit(rnd_n), .sticky(sticky_n),
        .out_valid(out_valid), .y(y), .flags(flags));
endmodule

`default_nettype wire
