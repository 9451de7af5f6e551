// fp_ip_standin: stand-in for the Xilinx Floating-Point Operator core (LogiCORE floating_point v7.1, PG060)
// that a Vitis HLS export instantiates as `<top>_<op>_..._ip` inside each floating-point wrapper, for
// co-simulating the export with Verilator (hls_export/README.md, "Floating-point stand-ins").
//
// Same ports as the IP configured by Vitis HLS (NonBlocking flow control, aclken, no aresetn, no tready, no
// tuser / tlast). The arithmetic is the matching rtl/fp operator, bit-exact with models/formats/number_format.py (not
// Xilinx's rounding: subnormals flush to zero, canonical NaN), so the co-simulation checks the HLS schedule and
// control, not the IP's numerics:
//   OPERATION "add"  fp_add (sub = 0)      "sub"  fp_add (sub = 1)     "mul" fp_mul
//             "div"  fp_div                "sqrt" fp_sqrt (operand a; the b channel is ignored)
//             "cmp"  fp_minmax (LATENCY 1): lt / eq / unordered, selected by the compare predicate
// Compare predicate (s_axis_operation_tdata[5:3]; bits [2:0] are 3'b100 = compare in the codes of the Vitis
// HLS fcmp wrappers and are ignored here, as are bits [7:6]); result in m_axis_result_tdata[0]:
//   000 unordered   001 a < b   010 a == b   011 a <= b   100 a > b   101 a != b   110 a >= b
//   111 condition code: m_axis_result_tdata[3:0] = {unordered, a > b, a < b, a == b}
// (codes as in the Vitis HLS fcmp wrappers' OP_* constants; `!=` is IEEE compareQuietNotEqual, true when
// unordered; the other predicates are false when unordered.) The cmp result bus is 8 bits, the rest 0.
//
// Timing: a result leaves exactly C_LATENCY enabled clock cycles after its operands (C_LATENCY counts the
// edge that samples them, as in the IP): the rtl/fp operator (its LATENCY) followed by a delay line of
// C_LATENCY - LATENCY stages. C_LATENCY below the operator's LATENCY (add/sub 4, mul 3, div MAN_BITS + 5,
// sqrt MAN_BITS + 4, cmp 1) stops elaboration with an error. m_axis_result_tvalid is s_axis_a_tvalid (and
// s_axis_b_tvalid for two-operand operations, s_axis_operation_tvalid for cmp) delayed the same way; it is 0
// after power-up (the IP has no reset here). Results come out whether or not tvalid is set (HLS ties the
// tvalids to 1 and reads tdata only).
// aclken = 0 freezes the whole core (no stage advances, every output holds): the operator and the delay lines
// run on a clock gated by aclken (fp_ip_clock_gate, a latch-based ICG model), since rtl/fp has no clock enable.
// Data widths: TDATA_W = W rounded up to whole bytes (the IP's AXI4-Stream tdata; 32 and 16 for binary32,
// binary16, bfloat16); operands are read from the low W bits.
`default_nettype none

module fp_ip_standin #(
    parameter  string OPERATION = "add",
    parameter  int    EXP_BITS  = 8,
    parameter  int    MAN_BITS  = 23,
    parameter  int    C_LATENCY = 4,
    localparam int    W         = 1 + EXP_BITS + MAN_BITS,
    localparam int    TDATA_W   = 8 * ((W + 7) / 8),
    localparam int    RESULT_W  = OPERATION == "cmp" ? 8 : TDATA_W
) (
    input  wire logic                aclk,
    input  wire logic                aclken,
    input  wire logic                s_axis_a_tvalid,
    input  wire logic [TDATA_W-1:0]  s_axis_a_tdata,
    input  wire logic                s_axis_b_tvalid,           // ignored by sqrt
    input  wire logic [TDATA_W-1:0]  s_axis_b_tdata,            // ignored by sqrt
    input  wire logic                s_axis_operation_tvalid,   // cmp only
    input  wire logic [7:0]          s_axis_operation_tdata,    // cmp only: the predicate
    output logic                     m_axis_result_tvalid,
    output logic [RESULT_W-1:0]      m_axis_result_tdata
);
    localparam bit IS_CMP      = OPERATION == "cmp";
    localparam bit IS_SQRT     = OPERATION == "sqrt";
    localparam int CMP_LATENCY = 1;   // fp_minmax's LATENCY parameter: its minimum
    // The rtl/fp operator's latency (rtl/fp/README.md); 0 for an unknown OPERATION (reported below).
    localparam int OP_LATENCY  = OPERATION == "add" || OPERATION == "sub" ? 4
                               : OPERATION == "mul"  ? 3
                               : OPERATION == "div"  ? MAN_BITS + 5
                               : OPERATION == "sqrt" ? MAN_BITS + 4
                               : OPERATION == "cmp"  ? CMP_LATENCY : 0;

    logic         gclk;   // aclk while aclken: every flop of the core runs on it
    logic [W-1:0] a;
    logic [W-1:0] b;      // not read by sqrt (see unused_inputs below)
    logic [W-1:0] y;      // the result of add / sub / mul / div / sqrt (0 and unused for cmp)
    logic         in_valid;

    // Inputs an operation does not read (b for sqrt, the predicate for all but cmp, the byte padding of
    // tdata): the ports exist for every operation, like the IP's full port list; and y, not used by cmp.
    /* verilator lint_off UNUSEDSIGNAL */
    logic unused_inputs;
    assign unused_inputs = ^{s_axis_a_tdata, s_axis_b_tdata, b, s_axis_b_tvalid, s_axis_operation_tvalid,
                             s_axis_operation_tdata, y};
    /* verilator lint_on UNUSEDSIGNAL */

    fp_ip_clock_gate u_gate (.clk(aclk), .en(aclken), .gclk(gclk));

    assign a        = s_axis_a_tdata[W-1:0];
    assign b        = s_axis_b_tdata[W-1:0];
    assign in_valid = s_axis_a_tvalid && (IS_SQRT || s_axis_b_tvalid) && (!IS_CMP || s_axis_operation_tvalid);

    // The valid line: in_valid delayed by C_LATENCY enabled cycles, 0 at power-up.
    fp_ip_delay #(.WIDTH(1), .DEPTH(C_LATENCY), .INIT(1'b0)) u_valid (
        .clk(gclk), .d(in_valid), .q(m_axis_result_tvalid)
    );

    // Operator outputs not used by the stand-in: out_valid (the valid line above replaces it, as the operators'
    // valid pipelines need a reset the IP does not have) and the event flags (the IP here has none).
    /* verilator lint_off UNUSEDSIGNAL */
    logic       op_valid;
    logic [2:0] op_flags;
    /* verilator lint_on UNUSEDSIGNAL */

    // Each branch drives y (cmp: op_y), the result OP_LATENCY cycles after its operands, and checks once at
    // the start of simulation that rtl/fp's LATENCY is still the OP_LATENCY assumed here (a parameter value
    // cannot read u_op.LATENCY: IEEE 1800 forbids hierarchical names there).
    logic [RESULT_W-1:0] op_y;

    if (!IS_CMP) begin : g_arith_result
        assign op_y = RESULT_W'(y);
    end

    if (OPERATION == "add" || OPERATION == "sub") begin : g_add
        fp_add #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_op (
            .clk(gclk), .rst(1'b0), .in_valid(1'b1), .a, .b, .sub(OPERATION == "sub"),
            .out_valid(op_valid), .y, .flags(op_flags)
        );
        initial if (u_op.LATENCY != OP_LATENCY) $fatal(1, "fp_ip_standin: fp_add LATENCY changed");
    end else if (OPERATION == "mul") begin : g_mul
        fp_mul #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_op (
            .clk(gclk), .rst(1'b0), .in_valid(1'b1), .a, .b, .out_valid(op_valid), .y, .flags(op_flags)
        );
        initial if (u_op.LATENCY != OP_LATENCY) $fatal(1, "fp_ip_standin: fp_mul LATENCY changed");
    end else if (OPERATION == "div") begin : g_div
        fp_div #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_op (
            .clk(gclk), .rst(1'b0), .in_valid(1'b1), .a, .b, .out_valid(op_valid), .y, .flags(op_flags)
        );
        initial if (u_op.LATENCY != OP_LATENCY) $fatal(1, "fp_ip_standin: fp_div LATENCY changed");
    end else if (OPERATION == "sqrt") begin : g_sqrt
        fp_sqrt #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_op (
            .clk(gclk), .rst(1'b0), .in_valid(1'b1), .a, .out_valid(op_valid), .y, .flags(op_flags)
        );
        initial if (u_op.LATENCY != OP_LATENCY) $fatal(1, "fp_ip_standin: fp_sqrt LATENCY changed");
    end else if (OPERATION == "cmp") begin : g_cmp
        // fp_minmax with CMP_LATENCY register stages; the predicate travels beside it through as many
        // registers, then selects the flag (combinational from registers only, so it holds while aclken = 0).
        logic       lt, eq, unordered, gt;
        logic [2:0] pred_q;
        /* verilator lint_off UNUSEDSIGNAL */
        logic [W-1:0] y_min, y_max;   // fp_minmax's minimum / maximum: not used by a compare
        /* verilator lint_on UNUSEDSIGNAL */

        fp_minmax #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .LATENCY(CMP_LATENCY)) u_op (
            .clk(gclk), .rst(1'b0), .in_valid(1'b1), .a, .b, .out_valid(op_valid), .y_min, .y_max,
            .lt, .eq, .unordered
        );
        fp_ip_delay #(.WIDTH(3), .DEPTH(CMP_LATENCY)) u_pred (
            .clk(gclk), .d(s_axis_operation_tdata[5:3]), .q(pred_q)
        );
        assign op_flags = 3'b000;   // fp_minmax has no event flags
        assign y        = '0;
        assign gt       = !(unordered || lt || eq);

        always_comb begin
            op_y = '0;
            unique case (pred_q)
                3'b000: op_y[0]   = unordered;
                3'b001: op_y[0]   = lt;
                3'b010: op_y[0]   = eq;
                3'b011: op_y[0]   = lt || eq;
                3'b100: op_y[0]   = gt;
                3'b101: op_y[0]   = !eq;
                3'b110: op_y[0]   = gt || eq;
                3'b111: op_y[3:0] = {unordered, gt, lt, eq};
            endcase
        end
        initial if (u_op.LATENCY != OP_LATENCY) $fatal(1, "fp_ip_standin: fp_minmax LATENCY changed");
    end else begin : g_bad_operation
        $fatal(1, "fp_ip_standin: OPERATION \"%s\" is not one of add, sub, mul, div, sqrt, cmp", OPERATION);
        assign y        = '0;
        assign op_valid = 1'b0;
        assign op_flags = 3'b000;
    end

    fp_ip_standin_pad #(.OPERATION(OPERATION), .WIDTH(RESULT_W), .OP_LATENCY(OP_LATENCY), .C_LATENCY(C_LATENCY))
        u_pad (.clk(gclk), .d(op_y), .q(m_axis_result_tdata));
endmodule

`default_nettype wire
