// fp_div: fully pipelined, correctly rounded floating-point divider (y = a / b).
//
// Algorithm: restoring radix-2 digit recurrence on the significands, one quotient bit per pipeline
// stage. With ma, mb the P = MAN_BITS+1 bit significands, the recurrence produces the P+2 bit
// quotient q = floor(ma * 2^(P+1) / mb) and its remainder; q lies in [2^P, 2^(P+2)), so after a
// 1-bit normalization there are P significant bits, a round bit, and the sticky bit
// (lower quotient bit | remainder != 0) for round to nearest, ties to even.
// Arithmetic contract (models/formats/number_format.py): subnormal inputs read as signed zero; the exact
// quotient is rounded at P bits with an unbounded exponent; a rounded result below the smallest
// normal flushes to a zero with the sign of the quotient; overflow gives +-inf. The result sign is
// always sign(a) XOR sign(b).
// Exceptions handled:
//   * NaN operand, 0 / 0, inf / inf           -> canonical quiet NaN
//   * inf / finite, non-zero finite / 0       -> +-inf (division by zero; subnormal divisors are 0)
//   * 0 / non-zero, finite / inf              -> +-0
//   * overflow -> +-inf, result below min normal after rounding -> +-0
// Event flags (models/formats/number_format.py, registered with y): flags = {invalid, underflow, overflow};
//   overflow / underflow: the rounding overflowed to +-inf / flushed a non-zero result to +-0 (from
//   fp_result_stage), invalid: a NaN made from non-NaN operands (0 / 0, inf / inf).
// Latency: LATENCY = MAN_BITS + 5 cycles (binary32: 28, binary16: 15, bfloat16: 12), II = 1.
//   stage 1            : unpack, classify, sign and exponent difference
//   stages 2 .. P+3    : one quotient bit each (P+2 = MAN_BITS+3 stages)
//   stage  P+4         : normalization, round to nearest even, exceptions, pack (output register)
// Only the valid bits are reset; each data register stage is enabled by the valid bit of the stage
// before it (the side band's shift register is free-running).
`default_nettype none

module fp_div #(
    parameter  int EXP_BITS = 8,
    parameter  int MAN_BITS = 23,
    localparam int W        = 1 + EXP_BITS + MAN_BITS,
    localparam int LATENCY  = MAN_BITS + 5
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
    localparam int NQ   = P + 2;             // quotient bits = recurrence stages
    localparam int EW   = EXP_BITS + 2;      // holds ea - eb + bias (signed)
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

    // The exception side band (fp_result_stage's `special`) and the exponent difference travel to the
    // last stage.
    logic                 invalid;
    logic [4:0]           special;
    logic signed [EW-1:0] exp_diff;

    always_comb begin
        invalid  = (a_zero && b_zero) || (a_inf && b_inf);
        special  = {a_nan || b_nan, invalid, a_inf || (b_zero && !a_zero), a_zero || b_inf, a_sign ^ b_sign};
        exp_diff = $signed({2'b00, a_exp}) - $signed({2'b00, b_exp}) + EW'(BIAS);
    end

    logic [4:0]           last_special;
    logic signed [EW-1:0] last_exp;

    fp_data_pipe #(.WIDTH(5 + EW), .DEPTH(NQ + 1)) u_side (
        .clk(clk), .d({special, exp_diff}), .q({last_special, last_exp})
    );

    // Per-stage registers of the recurrence; index 0 is stage 1 (unpack), index k holds the state
    // after k quotient bits. The divisor travels along with the operation.
    logic [P-1:0]  st_den [NQ+1];   // divisor significand
    logic [P:0]    st_rem [NQ+1];   // partial remainder (< 2 * divisor), already shifted
    logic [NQ-1:0] st_quo [NQ+1];   // quotient bits so far (LSB = newest)

    /* verilator lint_off UNUSEDSIGNAL */
    logic [LATENCY:0] stage_valid;   // [i]: in_valid i cycles ago; the recurrence reads [NQ:1]
    /* verilator lint_on UNUSEDSIGNAL */

    // Each stage takes an operation only when the stage before holds one (a clock enable on a board;
    // blocking temporaries inside the branch, so a simulator computes the stage only then).
    always_ff @(posedge clk) begin
        if (in_valid) begin
            st_den[0] <= b_sig;
            st_rem[0] <= {1'b0, a_sig};
            st_quo[0] <= '0;
        end
    end

    // ---------------- stages 2 .. NQ+1: restoring recurrence ----------------
    always_ff @(posedge clk) begin
        for (int k = 0; k < NQ; k++) begin
            if (stage_valid[k+1]) begin : b_digit
                automatic logic [P-1:0] trial;   // the low P bits of the difference: all the shift keeps
                automatic logic         qbit;
                trial = st_rem[k][P-1:0] - st_den[k];
                qbit  = (st_rem[k] >= {1'b0, st_den[k]});
                st_den[k+1] <= st_den[k];
                // The remainder after the subtraction is below the divisor (< 2^P): shift it left.
                st_rem[k+1] <= qbit ? {trial[P-1:0], 1'b0} : {st_rem[k][P-1:0], 1'b0};
                st_quo[k+1] <= {st_quo[k][NQ-2:0], qbit};
            end
        end
    end

    // ---------------- last stage: normalize, round, pack ----------------
    logic [NQ-1:0]        q;
    logic                 hi, rem_nz;
    logic [P-1:0]         sig_n;
    logic                 rnd_n, sticky_n;
    logic signed [EW-1:0] exp_n;

    always_comb begin
        q      = st_quo[NQ];
        rem_nz = (st_rem[NQ] != '0);
        hi     = q[NQ-1];             // ma >= mb: quotient in [1, 2)
        if (hi) begin
            sig_n    = q[NQ-1:2];
            rnd_n    = q[1];
            sticky_n = q[0] || rem_nz;
        end else begin
            sig_n    = q[NQ-2:1];
            rnd_n    = q[0];
            sticky_n = rem_nz;
        end
        exp_n = last_exp - {{(EW-1){1'b0}}, !hi};
    end

    fp_result_stage #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .EW(EW), .LATENCY(LATENCY)) u_result (
        .clk(clk), .rst(rst), .in_valid(in_valid), .special(last_special),
        .exp_in(exp_n), .sig_in(sig_n), .round_bit(rnd_n), .sticky(sticky_n),
        .stage_valid(stage_valid), .out_valid(out_valid), .y(y), .flags(flags));
endmodule

`default_nettype wire
