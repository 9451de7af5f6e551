// fp_result_stage: the last stage of fp_add, fp_mul, fp_div and fp_sqrt, and their valid pipeline.
//
// Rounds a normalized significand to nearest, ties to even, applies the exception overrides and
// packs the result (fp_round_pack), then registers y and flags; out_valid is the operator's
// in_valid delayed by LATENCY (fp_valid_pipe), so it arrives with that register.
// `special` is the operator's exception side band, {nan_operand, invalid, inf, zero, sign}:
//   * nan_operand: an operand is a NaN; invalid: the operation makes a NaN from non-NaN operands
//     (both give the canonical quiet NaN; invalid is also the invalid flag),
//   * inf / zero: the exact result is +-inf / +-0 (exceptions, not rounding),
//   * sign: the sign of the result, of the infinity and of the zero included.
// The other inputs are fp_round_pack's: exp_in (signed, EW bits), sig_in (hidden bit first),
// round_bit and sticky.
// Event flags (models/number_format.py): flags = {invalid, underflow, overflow}, registered with y;
// overflow / underflow from fp_round_pack (only for a finite non-zero exact result).
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
    output logic                      out_valid,
    output logic [W-1:0]              y,
    output logic [2:0]                flags       // {invalid, underflow, overflow}, with y
);
    logic         nan_operand, invalid, inf, zero, sign;
    logic [W-1:0] packed_y;
    logic         ovf, unf;

    assign {nan_operand, invalid, inf, zero, sign} = special;

    fp_round_pack #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .EW(EW)) u_round (
        .sign       (sign),
        .exp_in     (exp_in),
        .sig_in     (sig_in),
        .round_bit  (round_bit),
        .sticky     (sticky),
        .force_nan  (nan_operand || invalid),
        .force_inf  (inf),
        .force_zero (zero),
        .y          (packed_y),
        .overflow   (ovf),
        .underflow  (unf)
    );

    always_ff @(posedge clk) begin
        y     <= packed_y;
        flags <= {invalid, unf, ovf};
    end

    fp_valid_pipe #(.LATENCY(LATENCY)) u_valid (
        .clk(clk), .rst(rst), .in_valid(in_valid), .out_valid(out_valid)
    );
endmodule

`default_nettype wire
