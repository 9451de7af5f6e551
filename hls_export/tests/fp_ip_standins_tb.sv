// fp_ip_standins_tb: test harness for the Floating-Point Operator stand-ins (hls_export/fp_ip), driven by
// fp_ip_standins_main.cpp for hls_export/tests/test_fp_ip_standins.py.
//
// One stand-in per operation (add, sub, mul, div, sqrt, cmp) for one format, each with its own C_LATENCY
// (LAT_*), all fed the same operands. In front of them sits what a Vitis HLS floating-point wrapper puts there:
// one input buffer register on the ungated clock with clock enable ce (`if (ce) din0_buf1 <= din0`), feeding
// the IP's s_axis_*_tdata, with aclken = ce. So a result leaves LAT + 1 enabled cycles after the cycle that
// offered its operands (the buffer's cycle, then the IP's C_LATENCY), and flops on the ungated clock feed
// flops on the stand-ins' gated clock, as in an export.
// The lat_* outputs are the C_LATENCY values, so the driver checks against what was built.
`default_nettype none

module fp_ip_standins_tb #(
    parameter  int EXP_BITS = 8,
    parameter  int MAN_BITS = 23,
    parameter  int LAT_ADD  = 11,
    parameter  int LAT_SUB  = 4,
    parameter  int LAT_MUL  = 8,
    parameter  int LAT_DIV  = 30,
    parameter  int LAT_SQRT = 29,
    parameter  int LAT_CMP  = 2,
    localparam int W        = 1 + EXP_BITS + MAN_BITS
) (
    input  wire logic         clk,
    input  wire logic         ce,
    input  wire logic         in_valid,   // the operands' tvalid (a, b and the compare predicate)
    input  wire logic [W-1:0] a,
    input  wire logic [W-1:0] b,
    input  wire logic [7:0]   pred,       // s_axis_operation_tdata of the compare

    output logic              add_valid,
    output logic [W-1:0]      add_y,
    output logic              sub_valid,
    output logic [W-1:0]      sub_y,
    output logic              mul_valid,
    output logic [W-1:0]      mul_y,
    output logic              div_valid,
    output logic [W-1:0]      div_y,
    output logic              sqrt_valid,
    output logic [W-1:0]      sqrt_y,
    output logic              cmp_valid,
    output logic [7:0]        cmp_y,

    output logic [7:0]        lat_add,
    output logic [7:0]        lat_sub,
    output logic [7:0]        lat_mul,
    output logic [7:0]        lat_div,
    output logic [7:0]        lat_sqrt,
    output logic [7:0]        lat_cmp
);
    // the HLS wrapper's input buffer: ungated clock, clock enable
    logic         valid_buf;
    logic [W-1:0] a_buf, b_buf;
    logic [7:0]   pred_buf;

    always_ff @(posedge clk) begin
        if (ce) begin
            valid_buf <= in_valid;
            a_buf     <= a;
            b_buf     <= b;
            pred_buf  <= pred;
        end
    end

    fp_ip_standin #(.OPERATION("add"), .EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .C_LATENCY(LAT_ADD)) u_add (
        .aclk(clk), .aclken(ce), .s_axis_a_tvalid(valid_buf), .s_axis_a_tdata(a_buf), .s_axis_b_tvalid(valid_buf),
        .s_axis_b_tdata(b_buf), .s_axis_operation_tvalid(1'b0), .s_axis_operation_tdata(8'h00),
        .m_axis_result_tvalid(add_valid), .m_axis_result_tdata(add_y)
    );
    fp_ip_standin #(.OPERATION("sub"), .EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .C_LATENCY(LAT_SUB)) u_sub (
        .aclk(clk), .aclken(ce), .s_axis_a_tvalid(valid_buf), .s_axis_a_tdata(a_buf), .s_axis_b_tvalid(valid_buf),
        .s_axis_b_tdata(b_buf), .s_axis_operation_tvalid(1'b0), .s_axis_operation_tdata(8'h00),
        .m_axis_result_tvalid(sub_valid), .m_axis_result_tdata(sub_y)
    );
    fp_ip_standin #(.OPERATION("mul"), .EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .C_LATENCY(LAT_MUL)) u_mul (
        .aclk(clk), .aclken(ce), .s_axis_a_tvalid(valid_buf), .s_axis_a_tdata(a_buf), .s_axis_b_tvalid(valid_buf),
        .s_axis_b_tdata(b_buf), .s_axis_operation_tvalid(1'b0), .s_axis_operation_tdata(8'h00),
        .m_axis_result_tvalid(mul_valid), .m_axis_result_tdata(mul_y)
    );
    fp_ip_standin #(.OPERATION("div"), .EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .C_LATENCY(LAT_DIV)) u_div (
        .aclk(clk), .aclken(ce), .s_axis_a_tvalid(valid_buf), .s_axis_a_tdata(a_buf), .s_axis_b_tvalid(valid_buf),
        .s_axis_b_tdata(b_buf), .s_axis_operation_tvalid(1'b0), .s_axis_operation_tdata(8'h00),
        .m_axis_result_tvalid(div_valid), .m_axis_result_tdata(div_y)
    );
    fp_ip_standin #(.OPERATION("sqrt"), .EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .C_LATENCY(LAT_SQRT)) u_sqrt (
        .aclk(clk), .aclken(ce), .s_axis_a_tvalid(valid_buf), .s_axis_a_tdata(a_buf), .s_axis_b_tvalid(1'b0),
        .s_axis_b_tdata(b_buf), .s_axis_operation_tvalid(1'b0), .s_axis_operation_tdata(8'h00),
        .m_axis_result_tvalid(sqrt_valid), .m_axis_result_tdata(sqrt_y)
    );
    fp_ip_standin #(.OPERATION("cmp"), .EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .C_LATENCY(LAT_CMP)) u_cmp (
        .aclk(clk), .aclken(ce), .s_axis_a_tvalid(valid_buf), .s_axis_a_tdata(a_buf), .s_axis_b_tvalid(valid_buf),
        .s_axis_b_tdata(b_buf), .s_axis_operation_tvalid(valid_buf), .s_axis_operation_tdata(pred_buf),
        .m_axis_result_tvalid(cmp_valid), .m_axis_result_tdata(cmp_y)
    );

    assign lat_add  = 8'(LAT_ADD);
    assign lat_sub  = 8'(LAT_SUB);
    assign lat_mul  = 8'(LAT_MUL);
    assign lat_div  = 8'(LAT_DIV);
    assign lat_sqrt = 8'(LAT_SQRT);
    assign lat_cmp  = 8'(LAT_CMP);
endmodule

`default_nettype wire
