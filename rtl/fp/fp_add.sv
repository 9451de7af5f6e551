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
// Two forms, the same results and flags bit for bit (SHIFT_DSP):
//   * 0, fabric: the alignment and normalization are barrel shifters, the add a carry chain (LUT + CARRY8);
//   * 1, DSP48E2: the two shifts are multiplications by a power of two, as the vendor's full-DSP cores do.
//     Stage 2 is one DSP48E2, R = (big << A_EXP) + small * (+-2^k), with the product's sign giving the
//     subtraction and the post-adder the add: R holds the aligned sum scaled by 2^F, exactly, and the sum with
//     its sticky bit is R >> F with bit 0 or'ed with R's low F bits (for a subtraction too: R >> F is then the
//     floor of the exact difference, which agrees with the fabric form's difference of the sticky-or'ed
//     operand in every bit but bit 0, and there the sticky makes both 1). The power 2^k must fit the 18-bit
//     port (k <= 16): where the alignment distance range is wider (binary32), a far alignment (shift >= T)
//     first drops the small significand's low CF + 1 bits in LUTs, folding them into one sticky bit that
//     still lands below the sum's sticky position. Stage 3's left shift is (sum >> 2) * 2^(lz mod 16) in a
//     second DSP48E2 after a LUT step of 16 for lz >= 16; the two bits below it are shifted in LUTs.
// Only the valid bits are reset; each data register stage is enabled by the valid bit of the stage
// before it (its contents are meaningful only with that bit).
`default_nettype none

module fp_add #(
    parameter  int EXP_BITS  = 8,
    parameter  int MAN_BITS  = 23,
    parameter  bit SHIFT_DSP = 1'b0,   // 1: the shifts and the add in DSP48E2 (see above), 0: in the fabric
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
    logic [P-1:0]        s1_big;
    logic [5:0]          s1_side;
    logic [EXP_BITS-1:0] s1_exp;
    // each form reads its own: the small significand and the shift (fabric), or the DSP48E2's A and B (DSP)
    /* verilator lint_off UNUSEDSIGNAL */
    logic                s1_eff_sub;
    logic [P-1:0]        s1_small;
    logic [DW-1:0]       s1_shift;
    logic [P-1:0]        s1_dsp_a;
    logic signed [17:0]  s1_dsp_b;
    /* verilator lint_on UNUSEDSIGNAL */

    // The DSP form's alignment (SHIFT_DSP): R = (big << A_EXP) + A * B in one DSP48E2, A (at most 26 bits
    // unsigned) the small significand, B = +-2^k (18 bits signed); R is the aligned sum scaled by 2^F.
    localparam int  A_EXP = (SW > 16) ? 16 : SW;       // the power of a shift by 0 (the largest B holds)
    localparam int  F     = A_EXP - 3;                 // fraction bits of R below the sum's sticky position
    localparam bit  SPLIT = SW > 16;                   // far alignments first drop bits in LUTs
    localparam int  CF    = SPLIT ? SW - 16 : 0;       // far: small's bits [CF:0] become one sticky bit
    localparam int  T     = CF + 4;                    // far from this shift on (that sticky lands below bit 0)

    // B for a shift s: 2^k, or for a subtraction -2^k (ones from bit k up), k = A_EXP - s (near) or
    // A_EXP + CF - s (far: the significand was shifted right by CF + 1 and one bit back)
    function automatic logic [17:0] power_of(input int s, input bit negative);
        automatic int k = (SPLIT && s >= T) ? A_EXP + CF - s : A_EXP - s;
        for (int i = 0; i < 18; i++) power_of[i] = negative ? (i >= k) : (i == k);
    endfunction

    always_ff @(posedge clk) begin
        if (in_valid) begin : b_order
            automatic logic                a_sign, b_sign, bs_eff, a_inf, b_inf, a_nan, b_nan, swap;
            automatic logic [EXP_BITS-1:0] a_exp, b_exp, diff_full;
            automatic logic [P-1:0]        a_sig, b_sig, sm_sig;
            automatic logic [DW-1:0]       shift;
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
            sm_sig = swap ? a_sig : b_sig;
            shift = (diff_full > EXP_BITS'(SW)) ? DW'(SW) : diff_full[DW-1:0];
            s1_big     <= swap ? b_sig : a_sig;
            if (!SHIFT_DSP) begin
                s1_eff_sub <= a_sign ^ bs_eff;
                s1_small <= sm_sig;
                s1_shift <= shift;
            end else begin
                // A: the significand, or far, shifted right by CF + 1 with the dropped bits or'ed into bit 0
                // and one bit back; B from a table of the shift (each bit a function of a few bits)
                s1_dsp_a <= (SPLIT && shift >= DW'(T))
                            ? ((sm_sig >> (CF + 1)) << 1) | P'(|(sm_sig & P'((1 << (CF + 1)) - 1))) : sm_sig;
                s1_dsp_b <= '0;
                for (int sh = 0; sh <= SW; sh++) begin
                    if (shift == DW'(sh)) s1_dsp_b <= (a_sign ^ bs_eff) ? power_of(sh, 1'b1) : power_of(sh, 1'b0);
                end
            end
            s1_side    <= {a_nan || b_nan, a_inf && b_inf && (a_sign != bs_eff), a_inf || b_inf,
                           a_inf ? a_sign : bs_eff, a_sign && bs_eff, swap ? bs_eff : a_sign};
            s1_exp     <= swap ? b_exp : a_exp;
        end
    end

    // ---------------- stage 2: align and add ----------------
    logic [NW-1:0]       s2_sum;    // the sum with its sticky bit: a register (fabric) or from the DSP's (DSP)
    logic [5:0]          s2_side;
    logic [EXP_BITS-1:0] s2_exp;

    always_ff @(posedge clk) begin
        if (stage_valid[1]) begin
            s2_side <= s1_side;
            s2_exp  <= s1_exp;
        end
    end

    if (SHIFT_DSP) begin : g_dsp_add
        localparam int RW = NW + F;
        /* verilator lint_off UNUSEDSIGNAL */
        logic signed [47:0] dsp_p;   // the DSP48E2's P, as wide as its product and sum
        /* verilator lint_on UNUSEDSIGNAL */
        logic [RW-1:0]      s2_r;
        assign dsp_p = 48'($signed({1'b0, s1_big, {A_EXP{1'b0}}})) + $signed({1'b0, s1_dsp_a}) * s1_dsp_b;
        always_ff @(posedge clk) begin
            if (stage_valid[1]) s2_r <= dsp_p[RW-1:0];
        end
        assign s2_sum = {s2_r[RW-1:F+1], s2_r[F] | (|s2_r[F-1:0])};
    end else begin : g_fabric_add
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
            end
        end
    end

    // ---------------- stage 3: normalize ----------------
    logic [4:0]           s3_special;
    logic signed [EW-1:0] s3_exp;
    logic [NW-1:0]        s3_norm;
    logic [NW-P-1:0]      s3_low;  // DSP form: the low two sum bits shifted, or'ed into the round and sticky bits
    logic [LZW-1:0]       s2_lz;   // leading zeros of the sum

    always_comb begin : b_lzc
        s2_lz = LZW'(NW);
        for (int i = 0; i < NW; i++) begin
            if (s2_sum[i]) s2_lz = LZW'(NW - 1 - i);
        end
    end

    always_ff @(posedge clk) begin
        if (stage_valid[2]) begin : b_normalize
            automatic logic sum_zero;
            sum_zero = (s2_sum == '0);
            // An infinity takes its own sign, an exact zero sum the sign of a zero sum.
            s3_special <= {s2_side[5:3], sum_zero, s2_side[3] ? s2_side[2] : (sum_zero ? s2_side[1] : s2_side[0])};
            // The big operand's hidden bit sits at sum bit NW-2, so the leading one at NW-1-lz has
            // weight 2^(exp + 1 - lz - bias).
            s3_exp     <= $signed({{(EW-EXP_BITS){1'b0}}, s2_exp}) + EW'(1) - $signed({{(EW-LZW){1'b0}}, s2_lz});
        end
    end

    if (SHIFT_DSP) begin : g_dsp_norm
        // sum << lz = ((sum >> 2) << lz) << 2 | (sum[1:0] << lz), the two parts without common bits. The first:
        // a LUT step of 16 where the sum's top 16 bits are zero (lz >= 16), then a multiplication by
        // 2^(lz mod 16) in a DSP48E2 (26 x 16 bits for binary32), kept to its low NW - 2 bits (the sum has lz
        // leading zeros, so nothing above them is lost); the power's one-hot comes straight from the
        // leading-one flags, not from lz. The second is non-zero only for lz <= 2 (a sum with more leading
        // zeros comes from a shift <= 1, which leaves its low two bits zero), so it lies in the round and
        // sticky bits [3:0]: registered apart and or'ed in at rounding.
        localparam int DN = NW - 2;
        logic [DN-1:0] coarse;
        logic [15:0]   fine;
        logic [NW-1:0] lead;   // lead[i]: the sum's leading one is bit i
        always_comb begin : b_shift_operands
            for (int i = 0; i < NW; i++) lead[i] = s2_sum[i] && ((s2_sum >> (i + 1)) == '0);
            fine = '0;
            for (int i = 0; i < NW; i++) fine[(NW - 1 - i) % 16] |= lead[i];
            coarse = (NW > 16 && (s2_sum >> (NW > 16 ? NW - 16 : 0)) == '0) ? DN'(s2_sum[NW-1:2] << 16)
                                                                             : s2_sum[NW-1:2];
        end
        always_ff @(posedge clk) begin
            if (stage_valid[2]) begin : b_shift
                s3_norm <= {DN'(coarse * fine), 2'b00};
                s3_low  <= (NW - P)'(NW'(s2_sum[1:0]) << s2_lz);
            end
        end
    end else begin : g_fabric_norm
        always_ff @(posedge clk) begin
            if (stage_valid[2]) s3_norm <= s2_sum << s2_lz;
        end
        assign s3_low = '0;
    end

    // ---------------- stage 4: round and pack ----------------
    fp_result_stage #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .EW(EW), .LATENCY(LATENCY)) u_result (
        .clk(clk), .rst(rst), .in_valid(in_valid), .special(s3_special),
        .exp_in(s3_exp), .sig_in(s3_norm[NW-1:NW-P]), .round_bit(s3_norm[NW-P-1] | s3_low[NW-P-1]),
        .sticky(|(s3_norm[NW-P-2:0] | s3_low[NW-P-2:0])), .stage_valid(stage_valid), .out_valid(out_valid), .y(y),
        .flags(flags));
endmodule

`default_nettype wire
