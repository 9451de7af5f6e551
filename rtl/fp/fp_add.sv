// fp_add: pipelined floating-point adder / subtractor (y = a + b, or a - b when `sub` is 1).
//
// Arithmetic contract (models/number_format.py): subnormal inputs read as signed zero; the exact
// sum is rounded to nearest, ties to even, at MAN_BITS+1 bits with an unbounded exponent; a rounded
// result below the smallest normal flushes to a zero with the sign of the exact result; overflow
// gives +-inf.
// Exceptions handled:
//   * NaN operand, or inf - inf (effective subtraction of two infinities) -> canonical quiet NaN
//   * +-inf operand (otherwise)                                            -> that infinity
//   * exact zero result: x + (-x) = +0, (-0) + (-0) = -0, (+0) + (-0) = +0
//   * overflow -> +-inf, result below min normal after rounding -> +-0
// Event flags (models/number_format.py, registered with y): flags = {invalid, underflow, overflow};
//   overflow / underflow: the rounding overflowed to +-inf / flushed a non-zero result to +-0 (from
//   fp_round_pack), invalid: a NaN made from non-NaN operands (inf - inf).
// Latency: LATENCY = 4 cycles, one operation accepted per cycle (II = 1).
//   stage 1: unpack, classify, order operands by magnitude, exponent difference
//   stage 2: align the smaller significand (guard, round, sticky bits) and add / subtract
//   stage 3: leading-zero count and normalization
//   stage 4: round to nearest even, exceptions, pack (output register)
// Only the valid bits are reset; data registers are free-running.
`default_nettype none

module fp_add #(
    parameter  int EXP_BITS = 8,
    parameter  int MAN_BITS = 23,
    localparam int W        = 1 + EXP_BITS + MAN_BITS,
    localparam int LATENCY  = 4
) (
    input  wire logic         clk,
    input  wire logic         rst,        // synchronous, active high; clears the valid pipeline
    input  wire logic         in_valid,
    input  wire logic [W-1:0] a,
    input  wire logic [W-1:0] b,
    input  wire logic         sub,        // 1: y = a - b (flips b's sign)
    output logic              out_valid,
    output logic [W-1:0]      y,
    output logic [2:0]        flags       // {invalid, underflow, overflow}, with y
);
    localparam int P    = MAN_BITS + 1;          // significand bits
    localparam int SW   = P + 3;                 // significand + guard, round, sticky
    localparam int NW   = P + 4;                 // sum width (one carry bit)
    localparam int LZW  = $clog2(NW + 1);
    localparam int EW   = ((EXP_BITS > LZW) ? EXP_BITS : LZW) + 2;   // signed exponent width
    localparam int DW   = $clog2(SW + 1);        // alignment shift width (clamped to SW)

    // ---------------- stage 1: unpack and order ----------------
    logic                a_sign, b_sign, a_inf, b_inf, a_nan, b_nan;
    // The zero flags are not needed: flushed zeros unpack to exponent 0 and significand 0, which
    // the datapath adds exactly like any other operand.
    /* verilator lint_off UNUSEDSIGNAL */
    logic                a_zero, b_zero;
    /* verilator lint_on UNUSEDSIGNAL */
    logic [EXP_BITS-1:0] a_exp, b_exp;
    logic [P-1:0]        a_sig, b_sig;

    fp_unpack #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_unpack_a (
        .x(a), .sign(a_sign), .exp(a_exp), .sig(a_sig), .is_zero(a_zero), .is_inf(a_inf), .is_nan(a_nan)
    );
    fp_unpack #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_unpack_b (
        .x(b), .sign(b_sign), .exp(b_exp), .sig(b_sig), .is_zero(b_zero), .is_inf(b_inf), .is_nan(b_nan)
    );

    logic                bs_eff, swap, invalid;
    logic [EXP_BITS-1:0] diff_full;
    logic [DW-1:0]       diff_c;
    // Carried unchanged to stage 3: NaN operand, invalid, infinity and its sign, sign of an exact
    // zero sum, sign and exponent of the bigger operand.
    logic [5:0]          side;

    always_comb begin
        bs_eff    = b_sign ^ sub;
        // Zeros (and flushed subnormals) unpack to exponent 0 and significand 0, so they order
        // below every non-zero finite value.
        swap      = {b_exp, b_sig} > {a_exp, a_sig};
        diff_full = swap ? (b_exp - a_exp) : (a_exp - b_exp);
        diff_c    = (diff_full > EXP_BITS'(SW)) ? DW'(SW) : diff_full[DW-1:0];
        invalid   = a_inf && b_inf && (a_sign != bs_eff);
        side      = {a_nan || b_nan, invalid, a_inf || b_inf, a_inf ? a_sign : bs_eff,
                     a_sign && bs_eff, swap ? bs_eff : a_sign};
    end

    logic                s2_nan_op, s2_inv, s2_inf, s2_inf_sign, s2_zero_sign, s2_sign;
    logic [EXP_BITS-1:0] s2_exp;

    fp_data_pipe #(.WIDTH(6 + EXP_BITS), .DEPTH(2)) u_side (
        .clk(clk), .d({side, swap ? b_exp : a_exp}),
        .q({s2_nan_op, s2_inv, s2_inf, s2_inf_sign, s2_zero_sign, s2_sign, s2_exp})
    );

    // stage-1 registers of the datapath
    logic                s1_eff_sub;
    logic [P-1:0]        s1_big, s1_small;
    logic [DW-1:0]       s1_shift;

    always_ff @(posedge clk) begin
        s1_eff_sub <= a_sign ^ bs_eff;
        s1_big     <= swap ? b_sig : a_sig;
        s1_small   <= swap ? a_sig : b_sig;
        s1_shift   <= diff_c;
    end

    // ---------------- stage 2: align and add ----------------
    logic [2*SW-1:0] small_wide;
    logic [SW-1:0]   small_al;
    logic [NW-1:0]   sum;

    always_comb begin
        small_wide = {s1_small, 3'b000, {SW{1'b0}}} >> s1_shift;
        // Bits shifted out below the sticky position are OR-ed into it.
        small_al   = {small_wide[2*SW-1:SW+1], small_wide[SW] | (|small_wide[SW-1:0])};
        if (s1_eff_sub) sum = {1'b0, s1_big, 3'b000} - {1'b0, small_al};
        else            sum = {1'b0, s1_big, 3'b000} + {1'b0, small_al};
    end

    logic [NW-1:0] s2_sum;

    always_ff @(posedge clk) begin
        s2_sum <= sum;
    end

    // ---------------- stage 3: normalize ----------------
    logic [LZW-1:0] lz;
    logic           sum_zero;

    fp_lzc #(.WIDTH(NW)) u_lzc (.x(s2_sum), .count(lz));

    assign sum_zero = (s2_sum == '0);

    logic [4:0]           s3_special;
    logic signed [EW-1:0] s3_exp;
    logic [NW-1:0]        s3_norm;

    always_ff @(posedge clk) begin
        // An infinity takes its own sign, an exact zero sum the sign of a zero sum.
        s3_special <= {s2_nan_op, s2_inv, s2_inf, sum_zero,
                       s2_inf ? s2_inf_sign : (sum_zero ? s2_zero_sign : s2_sign)};
        // The big operand's hidden bit sits at sum bit NW-2, so the leading one at NW-1-lz has
        // weight 2^(exp + 1 - lz - bias).
        s3_exp     <= $signed({{(EW-EXP_BITS){1'b0}}, s2_exp}) + EW'(1) - $signed({{(EW-LZW){1'b0}}, lz});
        s3_norm    <= s2_sum << lz;
    end

    // ---------------- stage 4: round and pack ----------------
    fp_result_stage #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .EW(EW), .LATENCY(LATENCY)) u_result (
        .clk(clk), .rst(rst), .in_valid(in_valid), .special(s3_special),
        .exp_in(s3_exp), .sig_in(s3_norm[NW-1:NW-P]), .round_bit(s3_norm[NW-P-1]),
        .sticky(|s3_norm[NW-P-2:0]), .out_valid(out_valid), .y(y), .flags(flags));
endmodule

`default_nettype wire
