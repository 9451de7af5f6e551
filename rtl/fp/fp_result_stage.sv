// fp_result_stage: the last stage of fp_add, fp_mul, fp_div and fp_sqrt, and their valid pipeline.
//
// Rounds a normalized significand to nearest, ties to even, with an unbounded exponent, applies the
// exception overrides and packs the result, then registers y and flags; out_valid is the
// operator's in_valid delayed by LATENCY (fp_valid_pipe), so it arrives with that register.
// stage_valid[i] is in_valid delayed by i cycles: the operator enables its register stage i + 1
// with it, and this stage's register (stage LATENCY) takes its inputs when stage_valid[LATENCY-1]
// is 1 (y and flags hold otherwise: they are meaningful only with out_valid).
// `special` is the operator's exception side band, {nan_operand, invalid, inf, zero, sign}:
//   * nan_operand: an operand is a NaN; invalid: the operation makes a NaN from non-NaN operands
//     (both give the canonical quiet NaN; invalid is also the invalid flag),
//   * inf / zero: the exact result is +-inf / +-0 (exceptions, not rounding),
//   * sign: the sign of the result, of the infinity and of the zero included.
// The other inputs: exp_in (signed, EW bits: the biased exponent of sig_in's leading bit),
// sig_in (hidden bit first), round_bit and sticky.
// Rounding: a carry out of the significand (all ones rounded up) moves the exponent up by one; a
// rounded exponent >= 2^EXP_BITS - 1 overflows to +-inf, one <= 0 flushes to +-0.
// Event flags (models/formats/number_format.py): flags = {invalid, underflow, overflow}, registered with y;
// overflow / underflow only for a finite non-zero exact result.
// Latency: the y / flags register (1 cycle after the inputs); out_valid: LATENCY after in_valid.
// Only the valid bits are reset.
`default_nettype none

module fp_result_stage #(
    parameter  int EXP_BITS = 8,
    parameter  int MAN_BITS = 23,
    parameter  int EW       = EXP_BITS + 2,   // width of the signed exponent input
    parameter  int LATENCY  = 1,              // the operator's latency (in_valid to out_valid)
    localparam int W        = 1 + EXP_BITS + MAN_BITS
) (
    input  wire logic                 clk,
    input  wire logic                 rst,        // synchronous, active high; clears the valid pipeline
    input  wire logic                 in_valid,   // the operator's in_valid
    input  wire logic [4:0]           special,    // {nan_operand, invalid, inf, zero, sign}
    input  wire logic signed [EW-1:0] exp_in,
    input  wire logic [MAN_BITS:0]    sig_in,
    input  wire logic                 round_bit,
    input  wire logic                 sticky,
    output logic [LATENCY:0]          stage_valid,  // [i]: in_valid i cycles ago
    output logic                      out_valid,
    output logic [W-1:0]              y,
    output logic [2:0]                flags       // {invalid, underflow, overflow}, with y
);
    localparam logic signed [EW-1:0] EXP_ONES = EW'((1 << EXP_BITS) - 1);
    localparam logic [W-1:0]         QNAN     = {1'b0, {EXP_BITS{1'b1}}, 1'b1, {(MAN_BITS-1){1'b0}}};

    fp_valid_pipe #(.LATENCY(LATENCY)) u_valid (
        .clk(clk), .rst(rst), .in_valid(in_valid), .stage_valid(stage_valid), .out_valid(out_valid)
    );

    // The rounding is written inside the enabled branch, with the branch's own temporaries, so a
    // simulator computes it only for a stage that holds an operation (a clock-enabled register in
    // synthesis).
    always_ff @(posedge clk) begin
        if (stage_valid[LATENCY-1]) begin : b_round
            automatic logic                 nan_operand, invalid, inf, zero, sign, round_up, forced;
            automatic logic [MAN_BITS+1:0]  sum;      // significand after rounding, with carry
            automatic logic signed [EW-1:0] exp_r;
            {nan_operand, invalid, inf, zero, sign} = special;
            round_up = round_bit && (sticky || sig_in[0]);
            sum      = {1'b0, sig_in} + {{(MAN_BITS+1){1'b0}}, round_up};
            // A carry out means the significand was all ones and is now 10...0: mantissa bits are 0.
            exp_r    = exp_in + {{(EW-1){1'b0}}, sum[MAN_BITS+1]};
            if (nan_operand || invalid) y <= QNAN;
            else if (inf)               y <= {sign, {EXP_BITS{1'b1}}, {MAN_BITS{1'b0}}};
            else if (zero)              y <= {sign, {(EXP_BITS+MAN_BITS){1'b0}}};
            else if (exp_r >= EXP_ONES) y <= {sign, {EXP_BITS{1'b1}}, {MAN_BITS{1'b0}}};
            else if (exp_r <= 0)        y <= {sign, {(EXP_BITS+MAN_BITS){1'b0}}};
            else                        y <= {sign, exp_r[EXP_BITS-1:0], sum[MAN_BITS-1:0]};
            forced = nan_operand || invalid || inf || zero;
            flags <= {invalid, !forced && exp_r <= 0, !forced && exp_r >= EXP_ONES};
        end
    end
endmodule

`default_nettype wire
