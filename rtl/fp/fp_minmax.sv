// fp_minmax: IEEE 754-2019 minimum / maximum and quiet comparison flags.
//
// A combinational core followed by LATENCY (>= 1) pipeline register stages.
// Arithmetic contract (models/formats/number_format.py): subnormal inputs read as signed zero, so a
// subnormal operand that is selected comes out as +-0.
// Outputs and exceptions handled:
//   * y_min / y_max: IEEE 754-2019 minimum / maximum. A NaN operand (quiet or signalling, either
//     sign) gives the canonical quiet NaN; -0 < +0 (minimum(-0, +0) = -0, maximum(-0, +0) = +0);
//     +-inf order as usual.
//   * lt, eq: IEEE quiet comparisons a < b and a == b (here +0 == -0, and a subnormal equals zero);
//     both are 0 when unordered.
//   * unordered: a or b is NaN.
// Latency: LATENCY cycles (parameter, default 1), II = 1.
// Only the valid bits are reset; data registers are free-running.
`default_nettype none

module fp_minmax #(
    parameter  int EXP_BITS = 8,
    parameter  int MAN_BITS = 23,
    parameter  int LATENCY  = 1,
    localparam int W        = 1 + EXP_BITS + MAN_BITS
) (
    input  wire logic         clk,
    input  wire logic         rst,        // synchronous, active high; clears the valid pipeline
    input  wire logic         in_valid,
    input  wire logic [W-1:0] a,
    input  wire logic [W-1:0] b,
    output logic              out_valid,
    output logic [W-1:0]      y_min,
    output logic [W-1:0]      y_max,
    output logic              lt,
    output logic              eq,
    output logic              unordered
);
    localparam logic [W-1:0] QNAN = {1'b0, {EXP_BITS{1'b1}}, 1'b1, {(MAN_BITS-1){1'b0}}};
    localparam int           DW   = 2 * W + 3;

    // ---------------- combinational core ----------------
    logic                a_sign, b_sign, a_zero, b_zero, a_inf, b_inf, a_nan, b_nan;
    logic [EXP_BITS-1:0] a_exp, b_exp;
    logic [MAN_BITS:0]   a_sig, b_sig;

    fp_unpack #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_unpack_a (
        .x(a), .sign(a_sign), .exp(a_exp), .sig(a_sig), .is_zero(a_zero), .is_inf(a_inf), .is_nan(a_nan)
    );
    fp_unpack #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_unpack_b (
        .x(b), .sign(b_sign), .exp(b_exp), .sig(b_sig), .is_zero(b_zero), .is_inf(b_inf), .is_nan(b_nan)
    );

    logic [W-2:0] a_mag, b_mag;        // flushed magnitudes {exponent, mantissa}
    logic [W-1:0] a_ftz, b_ftz;        // flushed operands
    logic         mag_lt, mag_eq;
    logic         total_lt;            // a < b in the total order of non-NaN values with -0 < +0
    logic         nan_any;
    logic [W-1:0] c_min, c_max;
    logic         c_lt, c_eq;

    always_comb begin
        a_mag    = {a_exp, a_sig[MAN_BITS-1:0]};
        b_mag    = {b_exp, b_sig[MAN_BITS-1:0]};
        a_ftz    = {a_sign, a_mag};
        b_ftz    = {b_sign, b_mag};
        mag_lt   = a_mag < b_mag;
        mag_eq   = a_mag == b_mag;
        nan_any  = a_nan || b_nan;
        if (a_sign != b_sign) total_lt = a_sign;          // negative < positive, -0 < +0
        else if (a_sign)      total_lt = !mag_lt && !mag_eq;
        else                  total_lt = mag_lt;
        c_min    = nan_any ? QNAN : (total_lt ? a_ftz : b_ftz);
        c_max    = nan_any ? QNAN : (total_lt ? b_ftz : a_ftz);
        c_eq     = !nan_any && (mag_eq && (a_sign == b_sign || a_zero));   // +0 == -0
        c_lt     = !nan_any && total_lt && !(a_zero && b_zero);
    end

    // Not needed here: infinities order correctly as magnitudes, the zero test of one operand
    // suffices once the magnitudes are equal, and the hidden bits are implied by the exponents.
    /* verilator lint_off UNUSEDSIGNAL */
    logic unused_inf;
    assign unused_inf = a_inf ^ b_inf ^ b_zero ^ a_sig[MAN_BITS] ^ b_sig[MAN_BITS];
    /* verilator lint_on UNUSEDSIGNAL */

    // ---------------- LATENCY register stages ----------------
    fp_data_pipe #(.WIDTH(DW), .DEPTH(LATENCY)) u_out (
        .clk(clk), .d({c_min, c_max, c_lt, c_eq, nan_any}), .q({y_min, y_max, lt, eq, unordered})
    );

    // The core is a few comparisons and selects: its output stages are not enabled by the valid bits.
    /* verilator lint_off UNUSEDSIGNAL */
    logic [LATENCY:0] stage_valid;
    /* verilator lint_on UNUSEDSIGNAL */

    fp_valid_pipe #(.LATENCY(LATENCY)) u_valid (
        .clk(clk), .rst(rst), .in_valid(in_valid), .stage_valid(stage_valid), .out_valid(out_valid)
    );
endmodule

`default_nettype wire
