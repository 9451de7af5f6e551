// fp_sqrt: fully pipelined, correctly rounded floating-point square root (y = sqrt(a)).
//
// Algorithm: restoring radix-2 digit-by-digit square root, one root bit per pipeline stage.
// The significand (doubled when the unbiased exponent is odd, so the exponent halves exactly) is
// scaled to the 2P+2 bit integer N = M' * 2^(P+1) (P = MAN_BITS+1); the recurrence produces the
// P+1 bit root R = floor(sqrt(N)) in [2^P, 2^(P+1)) and the remainder N - R^2. R's top P bits are
// the significand, its LSB the round bit, and remainder != 0 the sticky bit (round to nearest even;
// an exact tie cannot occur for a square root, the rounding is the shared RNE logic anyway).
// Arithmetic contract (models/number_format.py): subnormal inputs read as signed zero. The result
// of a normal input is always normal (no overflow or underflow is possible).
// Exceptions handled:
//   * NaN, -inf, any negative non-zero number -> canonical quiet NaN
//   * +-0 (and +-subnormal, flushed)           -> +-0 (sqrt(-0) = -0)
//   * +inf                                     -> +inf
// Event flags (models/number_format.py, registered with y): flags = {invalid, underflow, overflow};
//   overflow / underflow: the rounding overflowed to +-inf / flushed a non-zero result to +-0 (from
//   fp_round_pack), invalid: a NaN made from non-NaN operands (a negative non-zero operand, -inf included; overflow and underflow
//   cannot happen).
// Latency: LATENCY = MAN_BITS + 4 cycles (binary32: 27, binary16: 14, bfloat16: 11), II = 1.
//   stage 1           : unpack, classify, exponent halving, radicand alignment
//   stages 2 .. P+2   : one root bit each (P+1 = MAN_BITS+2 stages)
//   stage  P+3        : round to nearest even, exceptions, pack (output register)
// Only the valid bits are reset; data registers are free-running.
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

    // Per-stage registers; index 0 is stage 1, index k holds the state after k root bits.
    logic                 st_nan  [NR+1];
    logic                 st_inv  [NR+1];
    logic                 st_inf  [NR+1];
    logic                 st_zero [NR+1];
    logic                 st_sign [NR+1];
    logic [EXP_BITS-1:0]  st_exp  [NR+1];
    logic [P:0]           st_rad  [NR+1];   // radicand bits still to bring down (MSB first)
    logic [RW-1:0]        st_rem  [NR+1];   // partial remainder
    logic [NR-1:0]        st_root [NR+1];   // root bits so far (LSB = newest)

    always_ff @(posedge clk) begin
        st_nan[0]  <= a_nan || (a_sign && !a_zero);
        st_inv[0]  <= a_sign && !a_zero && !a_nan;
        st_inf[0]  <= a_inf;
        st_zero[0] <= a_zero;
        st_sign[0] <= a_sign;
        st_exp[0]  <= exp_half;
        st_rad[0]  <= m_scaled;
        st_rem[0]  <= '0;
        st_root[0] <= '0;
    end

    // ---------------- stages 2 .. NR+1: restoring recurrence ----------------
    // N = M' * 2^(P+1) has 2P+2 bits: M' (P+1 bits) followed by P+1 zeros; each stage brings down
    // two bits, the shift register supplies M' and then zeros.
    logic [RW-1:0] cur   [NR];
    logic [RW-1:0] trial [NR];
    logic          rbit  [NR];

    always_comb begin
        for (int k = 0; k < NR; k++) begin
            cur[k]   = {st_rem[k][RW-3:0], st_rad[k][P:P-1]};
            trial[k] = {{(RW-NR-2){1'b0}}, st_root[k], 2'b01};
            rbit[k]  = (cur[k] >= trial[k]);
        end
    end

    always_ff @(posedge clk) begin
        for (int k = 0; k < NR; k++) begin
            st_nan[k+1]  <= st_nan[k];
            st_inv[k+1]  <= st_inv[k];
            st_inf[k+1]  <= st_inf[k];
            st_zero[k+1] <= st_zero[k];
            st_sign[k+1] <= st_sign[k];
            st_exp[k+1]  <= st_exp[k];
            st_rad[k+1]  <= {st_rad[k][P-2:0], 2'b00};
            st_rem[k+1]  <= rbit[k] ? (cur[k] - trial[k]) : cur[k];
            st_root[k+1] <= {st_root[k][NR-2:0], rbit[k]};
        end
    end

    // ---------------- last stage: round, pack ----------------
    logic [W-1:0] packed_y;
    logic         ovf, unf;

    fp_round_pack #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .EW(EW)) u_round (
        .sign       (st_sign[NR]),
        .exp_in     ($signed({2'b00, st_exp[NR]})),
        .sig_in     (st_root[NR][NR-1:1]),
        .round_bit  (st_root[NR][0]),
        .sticky     (st_rem[NR] != '0),
        .force_nan  (st_nan[NR]),
        .force_inf  (st_inf[NR]),
        .force_zero (st_zero[NR]),
        .y          (packed_y),
        .overflow   (ovf),
        .underflow  (unf)
    );

    always_ff @(posedge clk) begin
        y     <= packed_y;
        flags <= {st_inv[NR], unf, ovf};
    end

    fp_valid_pipe #(.LATENCY(LATENCY)) u_valid (
        .clk(clk), .rst(rst), .in_valid(in_valid), .out_valid(out_valid)
    );
endmodule

`default_nettype wire
