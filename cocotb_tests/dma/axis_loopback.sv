// axis_loopback: test fixture for the DMA model: a one-deep AXI4-Stream register slice (s_axis -> m_axis).
`default_nettype none

module axis_loopback #(
    parameter int W = 512
) (
    input  wire logic         ap_clk,
    input  wire logic         ap_rst_n,
    input  wire logic [W-1:0] s_axis_TDATA,
    input  wire logic         s_axis_TVALID,
    input  wire logic         s_axis_TLAST,
    output logic              s_axis_TREADY,
    output logic [W-1:0]      m_axis_TDATA,
    output logic              m_axis_TVALID,
    output logic              m_axis_TLAST,
    input  wire logic         m_axis_TREADY
);
    assign s_axis_TREADY = !m_axis_TVALID || m_axis_TREADY;

    always_ff @(posedge ap_clk) begin
        if (!ap_rst_n) begin
            m_axis_TVALID <= 1'b0;
        end else if (s_axis_TREADY) begin
            m_axis_TVALID <= s_axis_TVALID;
        end
        if (s_axis_TREADY && s_axis_TVALID) begin
            m_axis_TDATA <= s_axis_TDATA;
            m_axis_TLAST <= s_axis_TLAST;
        end
    end
endmodule

`default_nettype wire
