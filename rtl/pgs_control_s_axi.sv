// pgs_control_s_axi: the kernel's AXI4-Lite register file, in the style of a Vitis HLS
// `s_axilite port=return bundle=control` export (ap_ctrl_hs in register 0x00).
//
// Register map (byte addresses; every register 32 bits; the full table is in rtl/README.md):
//   0x00 AP_CTRL  bit0 ap_start (R/W/COH: set by writing 1, cleared when the kernel asserts ap_ready,
//                 unless auto_restart), bit1 ap_done (R/COR), bit2 ap_idle (R), bit3 ap_ready (R/COR),
//                 bit7 auto_restart (R/W), bit9 interrupt (R)
//   0x04 GIE      bit0 global interrupt enable (R/W)
//   0x08 IER      bit0 ap_done, bit1 ap_ready interrupt enable (R/W)
//   0x0C ISR      bit0 ap_done, bit1 ap_ready interrupt status (R/TOW: writing 1 toggles)
//   0x10 num_bodies      0x18 num_manifolds  0x20 iterations  0x28 dt         (R/W, 8-byte stride)
//   0x30 gravity_x       0x38 gravity_y      0x40 gravity_z   0x48 damping
//   0x50 options         bit0 interleaved pass order
//   0x58 status   (R/W1C) bits 7:0 sticky error flags (write 1 to clear), bits 15:8 code of the first
//                 error since the flags were last all clear (0 = none; cleared with the last flag)
//   0x60 cycles[31:0]  0x64 cycles[63:32]   (R) ap_start to ap_done of the last/current run
//   0x68 stall cycles  0x70 bubble cycles   0x78 issued manifold-passes   (R)
// Unmapped addresses read 0 and every access answers OKAY (RRESP/BRESP = 0).
// Ports s_axi_control_* (the HLS bundle name `control`). Handshake: one outstanding read and one outstanding write, like the HLS-generated slave (AWREADY
// in the idle write state, then WREADY, then BVALID; ARREADY in the idle read state, then RVALID).
// Reset: ap_rst_n, synchronous, active low.
`default_nettype none

module pgs_control_s_axi #(
    parameter int ADDR_W = 8,
    parameter int DATA_W = 32
) (
    input  wire                 ap_clk,
    input  wire                 ap_rst_n,
    // AXI4-Lite slave
    input  wire                 s_axi_control_AWVALID,
    output logic                s_axi_control_AWREADY,
    // the byte offset AxADDR[1:0] is ignored (32-bit registers, word-aligned access)
    /* verilator lint_off UNUSEDSIGNAL */
    input  wire  [ADDR_W-1:0]   s_axi_control_AWADDR,
    /* verilator lint_on UNUSEDSIGNAL */
    input  wire                 s_axi_control_WVALID,
    output logic                s_axi_control_WREADY,
    input  wire  [DATA_W-1:0]   s_axi_control_WDATA,
    input  wire  [DATA_W/8-1:0] s_axi_control_WSTRB,
    output logic                s_axi_control_BVALID,
    input  wire                 s_axi_control_BREADY,
    output logic [1:0]          s_axi_control_BRESP,
    input  wire                 s_axi_control_ARVALID,
    output logic                s_axi_control_ARREADY,
    /* verilator lint_off UNUSEDSIGNAL */
    input  wire  [ADDR_W-1:0]   s_axi_control_ARADDR,
    /* verilator lint_on UNUSEDSIGNAL */
    output logic                s_axi_control_RVALID,
    input  wire                 s_axi_control_RREADY,
    output logic [DATA_W-1:0]   s_axi_control_RDATA,
    output logic [1:0]          s_axi_control_RRESP,
    // `interrupt` is the Vitis HLS port name (it merely matches a C++ word)
    /* verilator lint_off SYMRSVDWORD */
    output logic                interrupt,
    /* verilator lint_on SYMRSVDWORD */
    // kernel side
    output logic                ap_start,
    input  wire                 ap_done,
    input  wire                 ap_idle,
    input  wire                 ap_ready,
    output logic [31:0]         num_bodies,
    output logic [31:0]         num_manifolds,
    output logic [31:0]         iterations,
    output logic [31:0]         dt,
    output logic [31:0]         gravity_x,
    output logic [31:0]         gravity_y,
    output logic [31:0]         gravity_z,
    output logic [31:0]         damping,
    output logic [31:0]         options,
    input  wire  [7:0]          err_set,      // pulse: set these sticky error flags
    input  wire  [7:0]          err_code,     // code recorded with the first error
    input  wire  [63:0]         stat_cycles,
    input  wire  [31:0]         stat_stalls,
    input  wire  [31:0]         stat_bubbles,
    input  wire  [31:0]         stat_issued
);
    localparam logic [ADDR_W-1:0] A_AP_CTRL = ADDR_W'(8'h00);
    localparam logic [ADDR_W-1:0] A_GIE     = ADDR_W'(8'h04);
    localparam logic [ADDR_W-1:0] A_IER     = ADDR_W'(8'h08);
    localparam logic [ADDR_W-1:0] A_ISR     = ADDR_W'(8'h0C);
    localparam logic [ADDR_W-1:0] A_NBODY   = ADDR_W'(8'h10);
    localparam logic [ADDR_W-1:0] A_NMANI   = ADDR_W'(8'h18);
    localparam logic [ADDR_W-1:0] A_ITERS   = ADDR_W'(8'h20);
    localparam logic [ADDR_W-1:0] A_DT      = ADDR_W'(8'h28);
    localparam logic [ADDR_W-1:0] A_GX      = ADDR_W'(8'h30);
    localparam logic [ADDR_W-1:0] A_GY      = ADDR_W'(8'h38);
    localparam logic [ADDR_W-1:0] A_GZ      = ADDR_W'(8'h40);
    localparam logic [ADDR_W-1:0] A_DAMP    = ADDR_W'(8'h48);
    localparam logic [ADDR_W-1:0] A_OPT     = ADDR_W'(8'h50);
    localparam logic [ADDR_W-1:0] A_STATUS  = ADDR_W'(8'h58);
    localparam logic [ADDR_W-1:0] A_CYC_LO  = ADDR_W'(8'h60);
    localparam logic [ADDR_W-1:0] A_CYC_HI  = ADDR_W'(8'h64);
    localparam logic [ADDR_W-1:0] A_STALL   = ADDR_W'(8'h68);
    localparam logic [ADDR_W-1:0] A_BUBBLE  = ADDR_W'(8'h70);
    localparam logic [ADDR_W-1:0] A_ISSUED  = ADDR_W'(8'h78);

    wire rst = !ap_rst_n;

    // ---------------- write channel ----------------
    typedef enum logic [1:0] {WR_IDLE, WR_DATA, WR_RESP} wr_state_t;
    wr_state_t         wstate;
    logic [ADDR_W-1:0] waddr;
    wire               aw_hs = s_axi_control_AWVALID && s_axi_control_AWREADY;
    wire               w_hs  = s_axi_control_WVALID && s_axi_control_WREADY;

    always_ff @(posedge ap_clk) begin
        if (rst) begin
            wstate <= WR_IDLE;
        end else begin
            unique case (wstate)
                WR_IDLE: if (s_axi_control_AWVALID) wstate <= WR_DATA;
                WR_DATA: if (s_axi_control_WVALID)  wstate <= WR_RESP;
                WR_RESP: if (s_axi_control_BREADY)  wstate <= WR_IDLE;
                default: wstate <= WR_IDLE;
            endcase
        end
    end
    always_ff @(posedge ap_clk) begin
        if (aw_hs) waddr <= {s_axi_control_AWADDR[ADDR_W-1:2], 2'b00};
    end
    assign s_axi_control_AWREADY = (wstate == WR_IDLE);
    assign s_axi_control_WREADY  = (wstate == WR_DATA);
    assign s_axi_control_BVALID  = (wstate == WR_RESP);
    assign s_axi_control_BRESP   = 2'b00;

    // byte-lane merge of a write into a 32-bit register
    function automatic logic [31:0] merge(input logic [31:0] old, input logic [31:0] data, input logic [3:0] strb);
        logic [31:0] r;
        for (int i = 0; i < 4; i++) r[i*8 +: 8] = strb[i] ? data[i*8 +: 8] : old[i*8 +: 8];
        return r;
    endfunction

    wire [31:0] wdata32 = 32'(s_axi_control_WDATA);
    wire [3:0]  wstrb4  = 4'(s_axi_control_WSTRB);

    // ---------------- read channel ----------------
    typedef enum logic {RD_IDLE, RD_DATA} rd_state_t;
    rd_state_t rstate;
    wire       ar_hs = s_axi_control_ARVALID && s_axi_control_ARREADY;
    wire [ADDR_W-1:0] raddr = {s_axi_control_ARADDR[ADDR_W-1:2], 2'b00};

    always_ff @(posedge ap_clk) begin
        if (rst) begin
            rstate <= RD_IDLE;
        end else begin
            unique case (rstate)
                RD_IDLE: if (s_axi_control_ARVALID) rstate <= RD_DATA;
                RD_DATA: if (s_axi_control_RREADY)  rstate <= RD_IDLE;
                default: rstate <= RD_IDLE;
            endcase
        end
    end
    assign s_axi_control_ARREADY = (rstate == RD_IDLE);
    assign s_axi_control_RVALID  = (rstate == RD_DATA);
    assign s_axi_control_RRESP   = 2'b00;

    // ---------------- control / interrupt registers ----------------
    logic       int_ap_start, int_auto_restart, int_ap_done, int_ap_ready, int_gie;
    logic [1:0] int_ier, int_isr;
    logic [7:0] int_err_flags, int_err_code;

    wire wr_ctrl   = w_hs && (waddr == A_AP_CTRL);
    wire rd_ctrl   = ar_hs && (raddr == A_AP_CTRL);

    always_ff @(posedge ap_clk) begin
        if (rst) begin
            int_ap_start     <= 1'b0;
            int_auto_restart <= 1'b0;
            int_ap_done      <= 1'b0;
            int_ap_ready     <= 1'b0;
            int_gie          <= 1'b0;
            int_ier          <= 2'b00;
            int_isr          <= 2'b00;
            int_err_flags    <= 8'h00;
            int_err_code     <= 8'h00;
        end else begin
            // ap_start: set by a write of 1, cleared on the ap_ready handshake unless auto_restart
            if (wr_ctrl && wstrb4[0] && wdata32[0]) int_ap_start <= 1'b1;
            else if (ap_ready) int_ap_start <= int_auto_restart;
            if (wr_ctrl && wstrb4[0]) int_auto_restart <= wdata32[7];
            // ap_done / ap_ready: set by the kernel, cleared on read (the kernel event wins)
            if (ap_done) int_ap_done <= 1'b1;
            else if (rd_ctrl) int_ap_done <= 1'b0;
            if (ap_ready) int_ap_ready <= 1'b1;
            else if (rd_ctrl) int_ap_ready <= 1'b0;
            if (w_hs && waddr == A_GIE && wstrb4[0]) int_gie <= wdata32[0];
            if (w_hs && waddr == A_IER && wstrb4[0]) int_ier <= wdata32[1:0];
            // ISR: set by enabled events, toggled by writes of 1
            for (int i = 0; i < 2; i++) begin
                if (int_ier[i] && (i == 0 ? ap_done : ap_ready)) int_isr[i] <= 1'b1;
                else if (w_hs && waddr == A_ISR && wstrb4[0] && wdata32[i]) int_isr[i] <= ~int_isr[i];
            end
            // status: sticky flags, write 1 to clear (a new error in the same cycle wins)
            begin
                logic [7:0] flags;
                flags = int_err_flags;
                if (w_hs && waddr == A_STATUS && wstrb4[0]) flags = flags & ~wdata32[7:0];
                if (flags == 8'h00) int_err_code <= 8'h00;
                if (err_set != 8'h00 && (flags == 8'h00)) int_err_code <= err_code;
                int_err_flags <= flags | err_set;
            end
        end
    end
    assign ap_start  = int_ap_start;
    assign interrupt = int_gie && (int_isr != 2'b00);

    // ---------------- argument registers (not reset: written by the host before ap_start) ----------
    logic [31:0] r_num_bodies, r_num_manifolds, r_iterations, r_dt, r_gx, r_gy, r_gz, r_damping, r_options;
    always_ff @(posedge ap_clk) begin
        if (rst) begin
            // arguments read 0 after reset, like the HLS slave's registers
            r_num_bodies    <= '0;
            r_num_manifolds <= '0;
            r_iterations    <= '0;
            r_dt            <= '0;
            r_gx            <= '0;
            r_gy            <= '0;
            r_gz            <= '0;
            r_damping       <= '0;
            r_options       <= '0;
        end else if (w_hs) begin
            unique case (waddr)
                A_NBODY: r_num_bodies    <= merge(r_num_bodies, wdata32, wstrb4);
                A_NMANI: r_num_manifolds <= merge(r_num_manifolds, wdata32, wstrb4);
                A_ITERS: r_iterations    <= merge(r_iterations, wdata32, wstrb4);
                A_DT:    r_dt            <= merge(r_dt, wdata32, wstrb4);
                A_GX:    r_gx            <= merge(r_gx, wdata32, wstrb4);
                A_GY:    r_gy            <= merge(r_gy, wdata32, wstrb4);
                A_GZ:    r_gz            <= merge(r_gz, wdata32, wstrb4);
                A_DAMP:  r_damping       <= merge(r_damping, wdata32, wstrb4);
                A_OPT:   r_options       <= merge(r_options, wdata32, wstrb4);
                default: ;
            endcase
        end
    end
    assign num_bodies    = r_num_bodies;
    assign num_manifolds = r_num_manifolds;
    assign iterations    = r_iterations;
    assign dt            = r_dt;
    assign gravity_x     = r_gx;
    assign gravity_y     = r_gy;
    assign gravity_z     = r_gz;
    assign damping       = r_damping;
    assign options       = r_options;

    // ---------------- read data (registered at the AR handshake) ----------------
    logic [31:0] rmux;
    always_comb begin
        unique case (raddr)
            A_AP_CTRL: rmux = {22'd0, interrupt, 1'b0, int_auto_restart, 3'd0, int_ap_ready, ap_idle,
                               int_ap_done, int_ap_start};
            A_GIE:     rmux = {31'd0, int_gie};
            A_IER:     rmux = {30'd0, int_ier};
            A_ISR:     rmux = {30'd0, int_isr};
            A_NBODY:   rmux = r_num_bodies;
            A_NMANI:   rmux = r_num_manifolds;
            A_ITERS:   rmux = r_iterations;
            A_DT:      rmux = r_dt;
            A_GX:      rmux = r_gx;
            A_GY:      rmux = r_gy;
            A_GZ:      rmux = r_gz;
            A_DAMP:    rmux = r_damping;
            A_OPT:     rmux = r_options;
            A_STATUS:  rmux = {16'd0, int_err_code, int_err_flags};
            A_CYC_LO:  rmux = stat_cycles[31:0];
            A_CYC_HI:  rmux = stat_cycles[63:32];
            A_STALL:   rmux = stat_stalls;
            A_BUBBLE:  rmux = stat_bubbles;
            A_ISSUED:  rmux = stat_issued;
            default:   rmux = 32'd0;
        endcase
    end
    always_ff @(posedge ap_clk) begin
        if (ar_hs) s_axi_control_RDATA <= DATA_W'(rmux);
    end
endmodule

`default_nettype wire
