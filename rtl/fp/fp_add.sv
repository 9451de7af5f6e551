// fp_add: pipelined floating-point adder / subtractor (y = a + b, or a - b when `sub` is 1).
//
// Arithmetic contract (models/formats/number_format.py): subnormal inputs read as signed zero; the exact
// sum is rounded to nearest, ties to even, at MAN_BITS+1 bits with an unbounded exponent; a rounded
// result below the smallest normal flushes to a zero with the sign of the exact result; overflow
// gives +-inf.
// Exceptions handled:
//   * NaN operand, or inf - inf (effective subtraction of two infinities) -> canonical quiet NaN
//   * +-inf operand (otherwise)                                            -> that infinity
//   * exact zero result: x + (-x) = +0, (-0) + (-0) = -0, (+0) + (-0) = +0
//   * overflow -> +-inf, result below min normal after rounding -> +-0
// Event flags (models/formats/number_format.py, registered with y): flags = {invalid, underflow, overflow};
//   overflow / underflow: the rounding overflowed to +-inf / flushed a non-zero result to +-0 (from
//   fp_result_stage), invalid: a NaN made from non-NaN operands (inf - inf).
// Latency: LATENCY = 4 cycles, one operation accepted per cycle (II = 1).
//   stage 1: unpack, classify, order operands by magnitude, exponent difference
//   stage 2: align the smaller significand (guard, round, sticky bits) and add / subtract
//   stage 3: leading-zero count and normalization
//   stage 4: round to nearest even, exceptions, pack (output register)
// Only the valid bits are reset; each data register stage is enabled by the valid bit of the stage
// before it (its contents are meaningful only with that bit).
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
    // Each register stage takes an operation only when the stage before holds one (stage_valid, a
    // clock enable on a board): its logic, the operands' unpack included, is written inside that
    // branch with the branch's own temporaries, so a simulator computes it only then.
    /* verilator lint_off UNUSEDSIGNAL */
    logic [LATENCY:0] stage_valid;   // [i]: in_valid i cycles ago; the stages enabled here read [2:1]
    /* verilator lint_on UNUSEDSIGNAL */

    // stage-1 registers: the datapath, and what travels unchanged to stage 3 (NaN operand,
    // invalid, infinity and its sign, sign of an exact zero sum, sign and exponent of the bigger
    // operand)
    logic                s1_eff_sub;
    logic [P-1:0]        s1_big, s1_small;
    logic [DW-1:0]       s1_shift;
    logic [5:0]          s1_side;
    logic [EXP_BITS-1:0] s1_exp;

    always_ff @(posedge clk) begin
        if (in_valid) begin : b_order
            automatic logic                a_sign, b_sign, bs_eff, a_inf, b_inf, a_nan, b_nan, swap;
            automatic logic [EXP_BITS-1:0] a_exp, b_exp, diff_full;
            automatic logic [P-1:0]        a_sig, b_sig;
            // the fields as fp_unpack gives them: a subnormal reads as a zero (significand 0)
            {a_sign, a_exp} = a[W-1:MAN_BITS];
            {b_sign, b_exp} = b[W-1:MAN_BITS];
            a_sig  = (a_exp == '0) ? '0 : {1'b1, a[MAN_BITS-1:0]};
            b_sig  = (b_exp == '0) ? '0 : {1'b1, b[MAN_BITS-1:0]};
            a_inf  = (a_exp == '1) && (a[MAN_BITS-1:0] == '0);
            b_inf  = (b_exp == '1) && (b[MAN_BITS-1:0] == '0);
            a_nan  = (a_exp == '1) && (a[MAN_BITS-1:0] != '0);
            b_nan  = (b_exp == '1) && (b[MAN_BITS-1:0] != '0);
            bs_eff = b_sign ^ sub;
            // Order by the raw magnitudes {exponent, mantissa}: the same order as the unpacked
            // {exponent, significand} (zeros and flushed subnormals, exponent 0, below everything
            // else), except between two operands of exponent 0, which are both zero here, where
            // either order gives the same result.
            swap   = b[W-2:0] > a[W-2:0];
            diff_full  = swap ? (b_exp - a_exp) : (a_exp - b_exp);
            s1_eff_sub <= a_sign ^ bs_eff;
            s1_big     <= swap ? b_sig : a_sig;
            s1_small   <= swap ? a_sig : b_sig;
            s1_shift   <= (diff_full > EXP_BITS'(SW)) ? DW'(SW) : diff_full[DW-1:0];
            s1_side    <= {a_nan || b_nan, a_inf && b_inf && (a_sign != bs_eff), a_inf || b_inf,
                           a_inf ? a_sign : bs_eff, a_sign && bs_eff, swap ? bs_eff : a_sign};
            s1_exp     <= swap ? b_exp : a_exp;
        end
    end

    // ---------------- stage 2: align and add ----------------
    logic [NW-1:0]       s2_sum;
    logic [5:0]          s2_side;
    logic [EXP_BITS-1:0] s2_exp;

    always_ff @(posedge clk) begin
        if (stage_valid[1]) begin : b_align
            automatic logic [SW-1:0] small_sh;
            automatic logic          lost;   // a one shifted out below the sticky position
            automatic logic [SW-1:0] small_al;
            small_sh = {s1_small, 3'b000} >> s1_shift;
            // The shifted-out bits are the small significand's bits below position shift - 3 (its
            // three appended zeros go first): a mask of the shift, not the shifter's lower half.
            lost = 1'b0;
            for (int i = 0; i < P; i++) lost |= s1_small[i] && (DW'(i + 3) < s1_shift);
            small_al = {small_sh[SW-1:1], small_sh[0] | lost};
            if (s1_eff_sub) s2_sum <= {1'b0, s1_big, 3'b000} - {1'b0, small_al};
            else            s2_sum <= {1'b0, s1_big, 3'b000} + {1'b0, small_al};
            s2_side <= s1_side;
            s2_exp  <= s1_exp;
        end
    end

    // ---------------- stage 3: normalize ----------------
    logic [4:0]           s3_special;
    logic signed [EW-1:0] s3_exp;
    logic [NW-1:0]        s3_norm;

    always_ff @(posedge clk) begin
        if (stage_valid[2]) begin : b_normalize
            automatic logic [LZW-1:0] lz;         // leading zeros of the sum
            automatic logic           sum_zero;
            lz = LZW'(NW);
            for (int i = 0; i < NW; i++) begin
                if (s2_sum[i]) lz = LZW'(NW - 1 - i);
            end
            sum_zero = (s2_sum == '0);
            // An infinity takes its own sign, an exact zero sum the sign of a zero sum.
            s3_special <= {s2_side[5:3], sum_zero, s2_side[3] ? s2_side[2] : (sum_zero ? s2_side[1] : s2_side[0])};
            // The big operand's hidden bit sits at sum bit NW-2, so the leading one at NW-1-lz has
            // weight 2^(exp + 1 - lz - bias).
            s3_exp     <= $signed({{(EW-EXP_BITS){1'b0}}, s2_exp}) + EW'(1) - $signed({{(EW-LZW){1'b0}}, lz});
            s3_norm    <= s2_sum << lz;
        end
    end

    // ---------------- stage 4: round and pack ----------------
    fp_result_stage #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .EW(EW), .LATENCY(LATENCY)) u_result (
        .clk(clk), .rst(rst), .in_valid(in_valid), .special(s3_special),
        .exp_in(s3_exp), .sig_in(s3_norm[NW-1:NW-P]), .round_bit(s3_norm[NW-P-1]),
        .sticky(|s3_norm[NW-P-2:0]), .stage_valid(stage_valid), .out_valid(out_valid), .y(y),
        .flags(flags));
endmodule

`default_nettype wire
