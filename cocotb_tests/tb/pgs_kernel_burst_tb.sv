// Transaction-level testbench top of the kernel: pgs_kernel with its three AXI4-Streams and its trace port
// served by burst buffers, so that cocotb moves data a burst (or a batch of trace records) at a time instead of
// once per cycle. The AXI4-Lite control port, the clock, the reset and the interrupt are the kernel's own,
// under the same names, so the host driver (cocotb_tests/tb/host_driver.py) programs it unchanged.
//
// The DDR bandwidth of the DMA preset is a token bucket shared by the three streams, as in the cycle-level
// model (cocotb_tests/tb/axi_dma.py DdrBandwidth): every cycle it gains ddr_rate_q16 (bytes per cycle, 16
// fraction bits) up to two constraint beats; a beat moves only with a beat's bytes of credit, spent when it is
// presented (MM2S) or taken (S2MM). ddr_unlimited: no cap (the "ideal" preset). Body-out, then constraints,
// then body-in draw on it in that order. tb_cycle counts clock edges from the start of the simulation; every
// trace record is stamped with the cycle it retired in.
`default_nettype none
module pgs_kernel_burst_tb #(
    parameter int EXP_BITS      = 8,
    parameter int MAN_BITS      = 23,
    parameter int MAX_BODIES    = 65536,
    parameter int MAX_MANIFOLDS = 262144,
    parameter int BODY_IN_W     = 128,
    parameter int CONS_W        = 512,
    parameter int BODY_OUT_W    = 128,
    parameter int IINV_W        = 3,   // inverse-inertia words per body-in record (the kernel's IINV_W)
    parameter int MU_W          = 0,   // friction-coefficient words per friction record (the kernel's MU_W)
    parameter int BURST         = 16,
    parameter int TRACE_BATCH   = 16,
    localparam int W            = 1 + EXP_BITS + MAN_BITS,
    localparam int TRACE_W      = 16 * W + 64,
    localparam int TRACE_SW     = TRACE_W + 64
) (
    input  wire                           ap_clk,
    input  wire                           ap_rst_n,
    input  wire                           s_axi_control_AWVALID,
    output logic                          s_axi_control_AWREADY,
    input  wire  [7:0]                    s_axi_control_AWADDR,
    input  wire                           s_axi_control_WVALID,
    output logic                          s_axi_control_WREADY,
    input  wire  [31:0]                   s_axi_control_WDATA,
    input  wire  [3:0]                    s_axi_control_WSTRB,
    output logic                          s_axi_control_BVALID,
    input  wire                           s_axi_control_BREADY,
    output logic [1:0]                    s_axi_control_BRESP,
    input  wire                           s_axi_control_ARVALID,
    output logic                          s_axi_control_ARREADY,
    input  wire  [7:0]                    s_axi_control_ARADDR,
    output logic                          s_axi_control_RVALID,
    input  wire                           s_axi_control_RREADY,
    output logic [31:0]                   s_axi_control_RDATA,
    output logic [1:0]                    s_axi_control_RRESP,
    output logic                          interrupt,
    // DDR bandwidth
    input  wire  [31:0]                   ddr_rate_q16,
    input  wire                           ddr_unlimited,
    // constraint MM2S
    input  wire  [BURST*CONS_W-1:0]       cons_burst_data,
    input  wire  [BURST-1:0]              cons_burst_last,
    input  wire  [15:0]                   cons_burst_beats,
    input  wire  [31:0]                   cons_burst_seq,
    output logic [31:0]                   cons_taken_seq,
    output logic                          cons_busy,
    // body-in MM2S
    input  wire  [BURST*BODY_IN_W-1:0]    body_in_burst_data,
    input  wire  [BURST-1:0]              body_in_burst_last,
    input  wire  [15:0]                   body_in_burst_beats,
    input  wire  [31:0]                   body_in_burst_seq,
    output logic [31:0]                   body_in_taken_seq,
    output logic                          body_in_busy,
    // body-out S2MM
    input  wire                           body_out_enable,
    input  wire  [31:0]                   body_out_limit,
    output logic [BURST*BODY_OUT_W-1:0]   body_out_burst_data,
    output logic [15:0]                   body_out_burst_beats,
    output logic                          body_out_burst_last,
    output logic [31:0]                   body_out_burst_seq,
    // trace records
    output logic [TRACE_BATCH*TRACE_SW-1:0] trace_batch,
    output logic [15:0]                   trace_fill,
    output logic [31:0]                   trace_batch_seq,
    output logic [63:0]                   tb_cycle
);
    localparam logic [47:0] CONS_Q     = 48'(CONS_W / 8) << 16;
    localparam logic [47:0] BODY_IN_Q  = 48'(BODY_IN_W / 8) << 16;
    localparam logic [47:0] BODY_OUT_Q = 48'(BODY_OUT_W / 8) << 16;
    localparam logic [47:0] CAP_Q      = 48'(2 * CONS_W / 8) << 16;

    logic [BODY_IN_W-1:0]  s_axis_body_TDATA;
    logic                  s_axis_body_TVALID, s_axis_body_TREADY, s_axis_body_TLAST;
    logic [CONS_W-1:0]     s_axis_cons_TDATA;
    logic                  s_axis_cons_TVALID, s_axis_cons_TREADY, s_axis_cons_TLAST;
    logic [BODY_OUT_W-1:0] m_axis_body_TDATA;
    logic                  m_axis_body_TVALID, m_axis_body_TREADY, m_axis_body_TLAST;
    logic                  trace_valid;
    logic [TRACE_W-1:0]    trace_data;

    initial tb_cycle = '0;
    always_ff @(posedge ap_clk) tb_cycle <= tb_cycle + 64'd1;

    // the DDR token bucket, one assign per value: in one always_comb block every output would depend on every
    // input (a false combinational loop through the kernel's handshakes, out_take -> cons_allow -> ... ->
    // out_allow, that the simulator warns about as UNOPTFLAT and has to order as one block)
    logic [47:0] credit;
    logic        out_take, cons_take, in_take;
    wire  [47:0] gained     = credit + 48'(ddr_rate_q16);
    wire  [47:0] avail      = gained > CAP_Q ? CAP_Q : gained;
    wire         out_allow  = ddr_unlimited || avail >= BODY_OUT_Q;
    wire  [47:0] after_out  = avail - (out_take && !ddr_unlimited ? BODY_OUT_Q : '0);
    wire         cons_allow = ddr_unlimited || after_out >= CONS_Q;
    wire  [47:0] after_cons = after_out - (cons_take && !ddr_unlimited ? CONS_Q : '0);
    wire         in_allow   = ddr_unlimited || after_cons >= BODY_IN_Q;
    wire  [47:0] after_in   = after_cons - (in_take && !ddr_unlimited ? BODY_IN_Q : '0);
    always_ff @(posedge ap_clk) credit <= ap_rst_n ? after_in : '0;

    axis_burst_source #(.W(CONS_W), .BURST(BURST)) u_cons (
        .clk(ap_clk), .rst_n(ap_rst_n), .burst_data(cons_burst_data), .burst_last(cons_burst_last),
        .burst_beats(cons_burst_beats), .burst_seq(cons_burst_seq), .taken_seq(cons_taken_seq), .busy(cons_busy),
        .allow(cons_allow), .take(cons_take), .tdata(s_axis_cons_TDATA), .tvalid(s_axis_cons_TVALID),
        .tlast(s_axis_cons_TLAST), .tready(s_axis_cons_TREADY));

    axis_burst_source #(.W(BODY_IN_W), .BURST(BURST)) u_body_in (
        .clk(ap_clk), .rst_n(ap_rst_n), .burst_data(body_in_burst_data), .burst_last(body_in_burst_last),
        .burst_beats(body_in_burst_beats), .burst_seq(body_in_burst_seq), .taken_seq(body_in_taken_seq),
        .busy(body_in_busy), .allow(in_allow), .take(in_take), .tdata(s_axis_body_TDATA),
        .tvalid(s_axis_body_TVALID), .tlast(s_axis_body_TLAST), .tready(s_axis_body_TREADY));

    axis_burst_sink #(.W(BODY_OUT_W), .BURST(BURST)) u_body_out (
        .clk(ap_clk), .rst_n(ap_rst_n), .enable(body_out_enable), .limit(body_out_limit), .allow(out_allow),
        .take(out_take), .tdata(m_axis_body_TDATA), .tvalid(m_axis_body_TVALID), .tlast(m_axis_body_TLAST),
        .tready(m_axis_body_TREADY), .burst_data(body_out_burst_data), .burst_beats(body_out_burst_beats),
        .burst_last(body_out_burst_last), .burst_seq(body_out_burst_seq));

    trace_batcher #(.RW(TRACE_W), .BATCH(TRACE_BATCH)) u_trace (
        .clk(ap_clk), .rst_n(ap_rst_n), .valid(trace_valid), .data(trace_data), .cycle(tb_cycle),
        .batch(trace_batch), .fill(trace_fill), .batch_seq(trace_batch_seq));

    pgs_kernel #(
        .EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .MAX_BODIES(MAX_BODIES), .MAX_MANIFOLDS(MAX_MANIFOLDS),
        .BODY_IN_W(BODY_IN_W), .CONS_W(CONS_W), .BODY_OUT_W(BODY_OUT_W),
        .IINV_W(IINV_W), .MU_W(MU_W)
    ) dut (
        .ap_clk, .ap_rst_n,
        .s_axi_control_AWVALID, .s_axi_control_AWREADY, .s_axi_control_AWADDR, .s_axi_control_WVALID,
        .s_axi_control_WREADY, .s_axi_control_WDATA, .s_axi_control_WSTRB, .s_axi_control_BVALID,
        .s_axi_control_BREADY, .s_axi_control_BRESP, .s_axi_control_ARVALID, .s_axi_control_ARREADY,
        .s_axi_control_ARADDR, .s_axi_control_RVALID, .s_axi_control_RREADY, .s_axi_control_RDATA,
        .s_axi_control_RRESP, .interrupt,
        .s_axis_body_TDATA, .s_axis_body_TVALID, .s_axis_body_TREADY, .s_axis_body_TLAST,
        .s_axis_cons_TDATA, .s_axis_cons_TVALID, .s_axis_cons_TREADY, .s_axis_cons_TLAST,
        .m_axis_body_TDATA, .m_axis_body_TVALID, .m_axis_body_TREADY, .m_axis_body_TLAST,
        .trace_valid, .trace_data);
endmodule
`default_nettype wire
