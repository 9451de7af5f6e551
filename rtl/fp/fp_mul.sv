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

    logic                 s1_nan, s1_inv, s1_inf, s1_zero, s1_sign;
    logic signed [EW-1:0] s1_exp;
    logic [P-1:0]         s1_a_sig, s1_b_sig;

    always_ff @(posedge clk) begin
        s1_nan   <= a_nan || b_nan || (a_inf && b_zero) || (a_zero && b_inf);
        s1_inv   <= (a_inf && b_zero) || (a_zero && b_inf);
        s1_inf   <= a_inf || b_inf;
        s1_zero  <= a_zero || b_zero;
        s1_sign  <= a_sign ^ b_sign;
        s1_exp   <= $signed({2'b00, a_exp}) + $signed({2'b00, b_exp}) - EW'(BIAS);
        s1_a_sig <= a_sig;
        s1_b_sig <= b_sig;
    end

    // ---------------- stage 2: multiply ----------------
    logic                 s2_nan, s2_inv, s2_inf, s2_zero, s2_sign;
    logic signed [EW-1:0] s2_exp;
    logic [2*P-1:0]       s2_prod;

    always_ff @(posedge clk) begin
        s2_nan  <= s1_nan;
        s2_inv  <= s1_inv;
        s2_inf  <= s1_inf;
        s2_zero <= s1_zero;
        s2_sign <= s1_sign;
        s2_exp  <= s1_exp;
        s2_prod <= {{P{1'b0}}, s1_a_sig} * {{P{1'b0}}, s1_b_sig};
    end

    // ---------------- stage 3: normalize, round, pack ----------------
    // The product of two significands in [1, 2) lies in [1, 4): bit 2P-1 tells which binade.
    logic                 hi;
    logic [P-1:0]         sig_n;
    logic                 rnd_n, sticky_n;
    logic signed [EW-1:0] exp_n;
    logic [W-1:0]         packed_y;
    logic                 ovf, unf;

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

    fp_round_pack #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .EW(EW)) u_round (
        .sign       (s2_sign),
        .exp_in     (exp_n),
        .sig_in     (sig_n),
        .round_bit  (rnd_n),
        .sticky     (sticky_n),
        .force_nan  (s2_nan),
        .force_inf  (s2_inf),
        .force_zero (s2_zero),
        .y          (packed_y),
        .overflow   (ovf),
        .underflow  (unf)
    );

    always_ff @(posedge clk) begin
        y     <= packed_y;
        flags <= {s2_inv, unf, ovf};
    end

    fp_valid_pipe #(.LATENCY(LATENCY)) u_valid (
        .clk(clk), .rst(rst), .in_valid(in_valid), .out_valid(out_valid)
    );
endmodule

`default_nettype wire
