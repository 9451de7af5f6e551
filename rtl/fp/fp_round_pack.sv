// fp_round_pack: round a normalized significand to nearest, ties to even, and pack the result
// (combinational). Shared by fp_add, fp_mul, fp_div and fp_sqrt.
//
// The value is (-1)^sign * 0.1{sig_in[MAN_BITS-1:0]}{round_bit}{sticky...} scaled so that sig_in's
// MSB (the hidden bit, 1 for a non-zero value) has weight 2^(exp_in - bias).
// Rounding is at MAN_BITS+1 significant bits with an unbounded exponent (the carry out of an
// all-ones significand bumps the exponent); then
//   * exponent >= all-ones  -> +-inf (overflow),
//   * exponent <= 0         -> +-0 with the given sign (tininess after rounding, flush to zero),
// Overrides, highest priority first: force_nan -> canonical quiet NaN (sign 0, exponent all ones,
// mantissa MSB set); force_inf -> +-inf; force_zero -> +-0 (sign taken from `sign`).
// Event flags (models/number_format.py): `overflow` when the rounded value took the +-inf branch and
// `underflow` when it took the flush-to-zero branch, both only without an override (the exact result was
// finite and non-zero); the operators add `invalid` themselves.
// Latency: 0 (combinational).
`default_nettype none

module fp_round_pack #(
    parameter int EXP_BITS = 8,
    parameter int MAN_BITS = 23,
    parameter int EW       = EXP_BITS + 2   // width of the signed exponent input
) (
    input  wire logic                          sign,
    input  wire logic signed [EW-1:0]          exp_in,
    input  wire logic [MAN_BITS:0]             sig_in,
    input  wire logic                          round_bit,
    input  wire logic                          sticky,
    input  wire logic                          force_nan,
    input  wire logic                          force_inf,
    input  wire logic                          force_zero,
    output logic [EXP_BITS+MAN_BITS:0]         y,
    output logic                               overflow,
    output logic                               underflow
);
    localparam logic signed [EW-1:0] EXP_ONES = EW'((1 << EXP_BITS) - 1);
    localparam logic [EXP_BITS+MAN_BITS:0] QNAN = {1'b0, {EXP_BITS{1'b1}}, 1'b1, {(MAN_BITS-1){1'b0}}};

    logic                   round_up;
    logic [MAN_BITS+1:0]    sum;      // significand after rounding, with carry
    logic signed [EW-1:0]   exp_r;

    always_comb begin
        round_up = round_bit && (sticky || sig_in[0]);
        sum      = {1'b0, sig_in} + {{(MAN_BITS+1){1'b0}}, round_up};
        // A carry out means the significand was all ones and is now 10...0: mantissa bits are 0.
        exp_r    = exp_in + {{(EW-1){1'b0}}, sum[MAN_BITS+1]};
        if (force_nan)               y = QNAN;
        else if (force_inf)          y = {sign, {EXP_BITS{1'b1}}, {MAN_BITS{1'b0}}};
        else if (force_zero)         y = {sign, {(EXP_BITS+MAN_BITS){1'b0}}};
        else if (exp_r >= EXP_ONES)  y = {sign, {EXP_BITS{1'b1}}, {MAN_BITS{1'b0}}};
        else if (exp_r <= 0)         y = {sign, {(EXP_BITS+MAN_BITS){1'b0}}};
        else                         y = {sign, exp_r[EXP_BITS-1:0], sum[MAN_BITS-1:0]};
        overflow  = !force_nan && !force_inf && !force_zero && exp_r >= EXP_ONES;
        underflow = !force_nan && !force_inf && !force_zero && exp_r <= 0;
    end
endmodule

`default_nettype wire
