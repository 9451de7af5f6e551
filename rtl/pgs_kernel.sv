// pgs_kernel: top level of the PGS contact-solver kernel, with the ports a Vitis HLS export
// (ap_ctrl_hs in an s_axilite `control` bundle, AXI4-Stream arguments with TLAST) would have.
//
//   ap_clk, ap_rst_n (synchronous, active low)
//   s_axi_control_*   AXI4-Lite slave: the register file (pgs_control_s_axi, map in rtl/README.md)
//   interrupt         GIE && (ISR != 0)
//   s_axis_body_*     body-in records (models/kernel/stream_format.py), num_bodies of them, TLAST on the last beat;
//                     14 + IINV_W words each (the inverse-inertia mode, models/setup/inertia.py)
//   s_axis_cons_*     constraint records, every pass of the step, TLAST on the last beat of each pass; a
//                     friction record carries 14 + MU_W words (MU_W = 1: the manifold's friction coefficient last;
//                     TANGENTS_ON_CHIP = 1: 8 + MU_W, without t0, t1, which the friction pipe derives from n)
//                     (WINDOW > 0: combined contact + friction records once per fetch, TLAST on each fetch's
//                     last beat; see pgs_window)
//   m_axis_body_*     body-out records in index order, TLAST on the last beat
//   m_axis_imp_*      IMPULSES_IN_RECORDS = 1 (the impulses travel with the records; no impulse RAM): one record
//                     per manifold slot of every pass, in slot order, TLAST on each pass's last: the updated
//                     impulses, IMP_OUT_W = 4 W bits rounded up to bytes (contact: lam[0..3]; friction: lamT[0..1],
//                     two zero words; a rejected slot all zeros), which the DMA writes to the DDR impulse buffer
//                     that the next passes' records read (models/kernel/stream_format.py). Idle (TVALID 0) otherwise.
//   trace_valid, trace_data (TRACE = 1; tied to 0 otherwise): one record per retired manifold-pass,
//     little-endian from bit 0: words 0..15 (W bits each) = impulses[0..3] (contact: lam[0..3];
//     friction: lamT[0..1], then two zero words), vA(3), wA(3), vB(3), wB(3) (the pipe's outputs,
//     static bodies included, as the golden PassRecord); then bits 16W+31:16W the manifold slot (record
//     index within the pass), 16W+47:16W+32 the iteration, bit 16W+48 the pass kind (0 contact,
//     1 friction), 15 zero bits: TRACE_W = 16W + 64 bits. With LANES > 1, lane l's record is at bits
//     [l*TRACE_W +: TRACE_W] with its own trace_valid bit l (the lanes of an issue retire together).
// Real-valued arguments (dt, gravity, damping) are the format's bit patterns in the low W bits of their
// 32-bit registers (W <= 32).
`default_nettype none

module pgs_kernel #(
    parameter int EXP_BITS       = 8,
    parameter int MAN_BITS       = 23,
    parameter int MAX_BODIES     = 65536,
    parameter int MAX_MANIFOLDS  = 262144,
    parameter int BODY_IN_W      = 128,
    parameter int CONS_W         = 512,
    parameter int BODY_OUT_W     = 128,
    parameter bit TRACE          = 1'b1,
    parameter int HAZARD_DEPTH   = 256,
    parameter int OUT_FIFO_DEPTH = 64,
    parameter int WINDOW         = 0,     // 0: every pass streams its records; > 0: the window kernel (pgs_window)
    parameter int WINDOW_CTX     = 8,
    parameter int LANES          = 1,     // manifolds issued per cycle (LANES > 1: window kernel only)
    parameter int IINV_W         = 3,     // inverse-inertia words of a body-in record: 1 scalar, 3 diagonal, 6 full
    parameter bit IMPULSES_IN_RECORDS = 1'b0,  // 0: accumulated impulses in the on-chip RAM; 1: in the records
    parameter int MU_W           = 0,     // friction-coefficient words of a friction record: 0 the constant, 1 a word
    parameter int BODY_BANKS     = 0,     // 0: body velocities as a multiport array; > 0: that many banks (LANES = 1)
    parameter bit TANGENTS_ON_CHIP = 1'b0, // 1: friction records without t0, t1, derived from n (pgs_friction_pipe_tb)
    parameter bit SOFT_CONTACT   = 1'b0,  // 1 (IINV_W = 3): the soft contact pipe (options bit 1, keep_dyn, keep_static)
    parameter int DELAY_BLOCK_MIN_DEPTH = 0,  // the pipes' delay lines at least this deep in block RAM (0: LUT RAM)
    parameter bit SHARED_DATAPATH = 1'b1, // 1: one datapath per lane for contact and friction; 0: a pipe of each kind
    parameter bit ADD_SHIFT_DSP  = 1'b0,  // 1: every fp_add of the pipes in its DSP48E2 form (fp_add's SHIFT_DSP, the
                                          // same results and latency); 0: in LUTs and carry chains
    parameter int C_S_AXI_CONTROL_ADDR_WIDTH = 8,
    parameter int C_S_AXI_CONTROL_DATA_WIDTH = 32,
    localparam int W             = 1 + EXP_BITS + MAN_BITS,
    localparam int TRACE_W       = 16 * W + 64,
    localparam int IMP_OUT_W     = (LANES * 4 * W + 7) / 8 * 8,   // one impulse-out record: LANES x 4 words
    localparam int AW            = C_S_AXI_CONTROL_ADDR_WIDTH,
    localparam int DW            = C_S_AXI_CONTROL_DATA_WIDTH
) (
    input  wire                   ap_clk,
    input  wire                   ap_rst_n,
    input  wire                   s_axi_control_AWVALID,
    output logic                  s_axi_control_AWREADY,
    input  wire  [AW-1:0]         s_axi_control_AWADDR,
    input  wire                   s_axi_control_WVALID,
    output logic                  s_axi_control_WREADY,
    input  wire  [DW-1:0]         s_axi_control_WDATA,
    input  wire  [DW/8-1:0]       s_axi_control_WSTRB,
    output logic                  s_axi_control_BVALID,
    input  wire                   s_axi_control_BREADY,
    output logic [1:0]            s_axi_control_BRESP,
    input  wire                   s_axi_control_ARVALID,
    output logic                  s_axi_control_ARREADY,
    input  wire  [AW-1:0]         s_axi_control_ARADDR,
    output logic                  s_axi_control_RVALID,
    input  wire                   s_axi_control_RREADY,
    output logic [DW-1:0]         s_axi_control_RDATA,
    output logic [1:0]            s_axi_control_RRESP,
    // `interrupt` is the Vitis HLS port name (it merely matches a C++ word)
    /* verilator lint_off SYMRSVDWORD */
    output logic                  interrupt,
    /* verilator lint_on SYMRSVDWORD */
    input  wire  [BODY_IN_W-1:0]  s_axis_body_TDATA,
    input  wire                   s_axis_body_TVALID,
    output logic                  s_axis_body_TREADY,
    input  wire                   s_axis_body_TLAST,
    input  wire  [CONS_W-1:0]     s_axis_cons_TDATA,
    input  wire                   s_axis_cons_TVALID,
    output logic                  s_axis_cons_TREADY,
    input  wire                   s_axis_cons_TLAST,
    output logic [BODY_OUT_W-1:0] m_axis_body_TDATA,
    output logic                  m_axis_body_TVALID,
    input  wire                   m_axis_body_TREADY,
    output logic                  m_axis_body_TLAST,
    output logic [IMP_OUT_W-1:0]  m_axis_imp_TDATA,
    output logic                  m_axis_imp_TVALID,
    input  wire                   m_axis_imp_TREADY,
    output logic                  m_axis_imp_TLAST,
    output logic [LANES-1:0]      trace_valid,
    output logic [LANES*TRACE_W-1:0] trace_data
);
    logic ap_rst_n_inv;
    assign ap_rst_n_inv = !ap_rst_n;

    logic        ap_start, ap_done, ap_idle;
    logic [31:0] num_bodies, num_manifolds, iterations, dt, gx, gy, gz, damping, options, lag, fetch_passes,
                 keep_dyn, keep_static;
    logic [7:0]  err_set, err_code, err_set_q, err_code_q;
    logic [2:0]  fp_set, fp_set_q;
    logic [63:0] stat_cycles;
    logic [31:0] stat_stalls, stat_bubbles, stat_issued, stat_rejected, stat_fp_overflow, stat_fp_underflow,
                 stat_fp_invalid;

    pgs_control_s_axi #(.ADDR_W(AW), .DATA_W(DW)) u_control (
        .ap_clk, .ap_rst_n,
        .s_axi_control_AWVALID, .s_axi_control_AWREADY, .s_axi_control_AWADDR, .s_axi_control_WVALID,
        .s_axi_control_WREADY, .s_axi_control_WDATA, .s_axi_control_WSTRB, .s_axi_control_BVALID,
        .s_axi_control_BREADY, .s_axi_control_BRESP, .s_axi_control_ARVALID, .s_axi_control_ARREADY,
        .s_axi_control_ARADDR, .s_axi_control_RVALID, .s_axi_control_RREADY, .s_axi_control_RDATA,
        .s_axi_control_RRESP, .interrupt,
        .ap_start, .ap_done, .ap_idle, .ap_ready(ap_done),
        .num_bodies, .num_manifolds, .iterations, .dt, .gravity_x(gx), .gravity_y(gy), .gravity_z(gz),
        .damping, .options, .lag, .fetch_passes, .keep_dyn, .keep_static, .err_set(err_set_q), .err_code(err_code_q),
        .fp_set(fp_set_q), .stat_cycles, .stat_stalls, .stat_bubbles, .stat_issued, .stat_rejected, .stat_fp_overflow,
        .stat_fp_underflow, .stat_fp_invalid);

    // the error and floating-point event flags reach the status registers a cycle after they are raised, so that no
    // path runs from the issue decision or a datapath's flags into the registers' update in the same cycle
    always_ff @(posedge ap_clk) begin
        if (ap_rst_n_inv) {err_set_q, err_code_q, fp_set_q} <= '0;
        else              {err_set_q, err_code_q, fp_set_q} <= {err_set, err_code, fp_set};
    end

    pgs_sequencer #(
        .EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .MAX_BODIES(MAX_BODIES), .MAX_MANIFOLDS(MAX_MANIFOLDS),
        .BODY_IN_W(BODY_IN_W), .CONS_W(CONS_W), .BODY_OUT_W(BODY_OUT_W), .TRACE(TRACE),
        .HAZARD_DEPTH(HAZARD_DEPTH), .OUT_FIFO_DEPTH(OUT_FIFO_DEPTH), .WINDOW(WINDOW), .WINDOW_CTX(WINDOW_CTX),
        .LANES(LANES), .IINV_W(IINV_W), .IMPULSES_IN_RECORDS(IMPULSES_IN_RECORDS), .MU_W(MU_W),
        .BODY_BANKS(BODY_BANKS), .TANGENTS_ON_CHIP(TANGENTS_ON_CHIP), .SOFT_CONTACT(SOFT_CONTACT),
        .DELAY_BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH), .SHARED_DATAPATH(SHARED_DATAPATH),
        .ADD_SHIFT_DSP(ADD_SHIFT_DSP)
    ) u_seq (
        .clk(ap_clk), .rst(ap_rst_n_inv), .start(ap_start), .idle(ap_idle), .done(ap_done),
        .arg_num_bodies(num_bodies), .arg_num_manifolds(num_manifolds), .arg_iterations(iterations),
        .arg_dt(dt[W-1:0]), .arg_gx(gx[W-1:0]), .arg_gy(gy[W-1:0]), .arg_gz(gz[W-1:0]),
        .arg_damping(damping[W-1:0]), .opt_interleaved(options[pgs_regs_pkg::OPT_INTERLEAVED_BIT]), .arg_lag(lag), .arg_fetch_passes(fetch_passes),
        .opt_soft(options[pgs_regs_pkg::OPT_SOFT_CONTACT_BIT]), .arg_keep_dyn(keep_dyn[W-1:0]),
        .arg_keep_static(keep_static[W-1:0]),
        .s_body_tdata(s_axis_body_TDATA), .s_body_tvalid(s_axis_body_TVALID), .s_body_tready(s_axis_body_TREADY),
        .s_body_tlast(s_axis_body_TLAST),
        .s_cons_tdata(s_axis_cons_TDATA), .s_cons_tvalid(s_axis_cons_TVALID), .s_cons_tready(s_axis_cons_TREADY),
        .s_cons_tlast(s_axis_cons_TLAST),
        .m_body_tdata(m_axis_body_TDATA), .m_body_tvalid(m_axis_body_TVALID), .m_body_tready(m_axis_body_TREADY),
        .m_body_tlast(m_axis_body_TLAST),
        .m_imp_tdata(m_axis_imp_TDATA), .m_imp_tvalid(m_axis_imp_TVALID), .m_imp_tready(m_axis_imp_TREADY),
        .m_imp_tlast(m_axis_imp_TLAST),
        .err_set, .err_code, .fp_set, .stat_cycles, .stat_stalls, .stat_bubbles, .stat_issued, .stat_rejected,
        .stat_fp_overflow, .stat_fp_underflow, .stat_fp_invalid, .trace_valid, .trace_data);

    // Not needed (Verilator's *unused* naming convention): the register bits above the format's width
    // and the reserved option bits.
    generate
        if (W < 32) begin : g_unused_hi
            wire unused_hi = ^{dt[31:W], gx[31:W], gy[31:W], gz[31:W], damping[31:W], keep_dyn[31:W],
                               keep_static[31:W]};
        end
    endgenerate
    wire unused_opt = ^(options & ~((32'd1 << pgs_regs_pkg::OPT_INTERLEAVED_BIT)
                                    | (32'd1 << pgs_regs_pkg::OPT_SOFT_CONTACT_BIT)));   // the other options bits
endmodule

`default_nettype wire
