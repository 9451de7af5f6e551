// pgs_control_s_axi: the kernel's AXI4-Lite register file, in the style of a Vitis HLS
// `s_axilite port=return bundle=control` export (ap_ctrl_hs in register 0x00).
//
// Register map (byte addresses; every register 32 bits; the full table is in rtl/README.md). The offsets, bit
// positions and error codes come from pgs_regs_pkg (generated from models/kernel/register_map.py, the one definition):
//   0x00 AP_CTRL  bit0 ap_start (R/W/COH: set by writing 1, cleared when the kernel asserts ap_ready,
//                 unless auto_restart), bit1 ap_done (R/COR), bit2 ap_idle (R), bit3 ap_ready (R/COR),
//                 bit7 auto_restart (R/W), bit9 interrupt (R)
//   0x04 GIE      bit0 global interrupt enable (R/W)
//   0x08 IER      bit0 ap_done, bit1 ap_ready interrupt enable (R/W)
//   0x0C ISR      bit0 ap_done, bit1 ap_ready interrupt status (R/TOW: writing 1 toggles)
//   0x10 num_bodies      0x18 num_manifolds  0x20 iterations  0x28 dt         (R/W, 8-byte stride)
//   0x30 gravity_x       0x38 gravity_y      0x40 gravity_z   0x48 damping
//   0x50 options         bit0 interleaved pass order, bit1 soft contact (SOFT_CONTACT kernel)
//   0x58 status   (R/W1C) sticky error flags (write 1 to clear): bits 7:0 codes 1..8 (bit k-1 for code
//                 k), bits 31:24 codes 9..16 (bit 24+k-9); bits 15:8 code of the first error since the
//                 flags were last all clear (0 = none; cleared with the last flag); bits 23:16 read 0
//   0x60 cycles[31:0]  0x64 cycles[63:32]   (R) ap_start to ap_done of the last/current run
//   0x68 stall cycles  0x70 bubble cycles   0x78 issued manifold-passes   0x7C rejected manifold-passes (R)
//   0x80 / 0x84 / 0x88 floating-point overflow / underflow / invalid (NaN) events of the run (R)
//   0x8C fp_status (R/W1C) sticky event flags: bit 0 overflow, bit 1 underflow, bit 2 invalid
//   0x90 lag             0x98 fetch_passes  (R/W, 8-byte stride) arguments of a window kernel (WINDOW > 0)
//   0xA0 keep_dyn        0xA8 keep_static   (R/W, 8-byte stride) arguments of a soft contact kernel (SOFT_CONTACT)
// Errors raised here: code 8 = AP_CTRL written with ap_start = 1 while a run is pending or busy (the
// write does nothing else); code 9 = an access to an unmapped address. The upper words of the 8-byte
// argument slots (0x14, 0x1C, ... 0x54, 0x94, 0x9C, 0xA4, 0xAC) are reserved: they read 0, ignore writes and answer OKAY (a host
// may write 64-bit arguments); every other address without a register reads 0, ignores writes and
// answers SLVERR (RRESP/BRESP = 2'b10).
// Ports s_axi_control_* (the HLS bundle name `control`). Handshake: one outstanding read and one outstanding write, like the HLS-generated slave (AWREADY
// in the idle write state, then WREADY, then BVALID; ARREADY in the idle read state, then RVALID).
// Reset: ap_rst_n, synchronous, active low.
`default_nettype none

module pgs_control_s_axi
    import pgs_regs_pkg::*;
#(
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
    output logic [31:0]         lag,
    output logic [31:0]         fetch_passes,
    output logic [31:0]         keep_dyn,
    output logic [31:0]         keep_static,
    input  wire  [7:0]          err_set,      // pulse: set these sticky error flags (codes 1..8)
    input  wire  [7:0]          err_code,     // code recorded with the first error
    input  wire  [2:0]          fp_set,       // pulse: set these sticky event flags
    input  wire  [63:0]         stat_cycles,
    input  wire  [31:0]         stat_stalls,
    input  wire  [31:0]         stat_bubbles,
    input  wire  [31:0]         stat_issued,
    input  wire  [31:0]         stat_rejected,
    input  wire  [31:0]         stat_fp_overflow,
    input  wire  [31:0]         stat_fp_underflow,
    input  wire  [31:0]         stat_fp_invalid
);
    localparam logic [ADDR_W-1:0] A_AP_CTRL = ADDR_W'(REG_AP_CTRL);
    localparam logic [ADDR_W-1:0] A_GIE     = ADDR_W'(REG_GIE);
    localparam logic [ADDR_W-1:0] A_IER     = ADDR_W'(REG_IER);
    localparam logic [ADDR_W-1:0] A_ISR     = ADDR_W'(REG_ISR);
    localparam logic [ADDR_W-1:0] A_NBODY   = ADDR_W'(REG_NUM_BODIES);
    localparam logic [ADDR_W-1:0] A_NMANI   = ADDR_W'(REG_NUM_MANIFOLDS);
    localparam logic [ADDR_W-1:0] A_ITERS   = ADDR_W'(REG_ITERATIONS);
    localparam logic [ADDR_W-1:0] A_DT      = ADDR_W'(REG_DT);
    localparam logic [ADDR_W-1:0] A_GX      = ADDR_W'(REG_GRAVITY_X);
    localparam logic [ADDR_W-1:0] A_GY      = ADDR_W'(REG_GRAVITY_Y);
    localparam logic [ADDR_W-1:0] A_GZ      = ADDR_W'(REG_GRAVITY_Z);
    localparam logic [ADDR_W-1:0] A_DAMP    = ADDR_W'(REG_DAMPING);
    localparam logic [ADDR_W-1:0] A_OPT     = ADDR_W'(REG_OPTIONS);
    localparam logic [ADDR_W-1:0] A_STATUS  = ADDR_W'(REG_STATUS);
    localparam logic [ADDR_W-1:0] A_CYC_LO  = ADDR_W'(REG_CYCLES_LO);
    localparam logic [ADDR_W-1:0] A_CYC_HI  = ADDR_W'(REG_CYCLES_HI);
    localparam logic [ADDR_W-1:0] A_STALL   = ADDR_W'(REG_STALLS);
    localparam logic [ADDR_W-1:0] A_BUBBLE  = ADDR_W'(REG_BUBBLES);
    localparam logic [ADDR_W-1:0] A_ISSUED  = ADDR_W'(REG_ISSUED);
    localparam logic [ADDR_W-1:0] A_REJECT  = ADDR_W'(REG_REJECTED);
    localparam logic [ADDR_W-1:0] A_FP_OVF  = ADDR_W'(REG_FP_OVERFLOW);
    localparam logic [ADDR_W-1:0] A_FP_UNF  = ADDR_W'(REG_FP_UNDERFLOW);
    localparam logic [ADDR_W-1:0] A_FP_INV  = ADDR_W'(REG_FP_INVALID);
    localparam logic [ADDR_W-1:0] A_FP_STAT = ADDR_W'(REG_FP_STATUS);
    localparam logic [ADDR_W-1:0] A_LAG     = ADDR_W'(REG_LAG);
    localparam logic [ADDR_W-1:0] A_FETCH   = ADDR_W'(REG_FETCH_PASSES);
    localparam logic [ADDR_W-1:0] A_KEEP_D  = ADDR_W'(REG_KEEP_DYN);
    localparam logic [ADDR_W-1:0] A_KEEP_S  = ADDR_W'(REG_KEEP_STATIC);
    localparam logic [1:0]        OKAY      = 2'b00;
    localparam logic [1:0]        SLVERR    = 2'b10;

    // a register (or the reserved upper word of an argument slot) answers at this word address
    function automatic logic mapped(input logic [ADDR_W-1:0] a);
        unique case (a)
            A_AP_CTRL, A_GIE, A_IER, A_ISR, A_NBODY, A_NMANI, A_ITERS, A_DT, A_GX, A_GY, A_GZ, A_DAMP, A_OPT,
            A_STATUS, A_CYC_LO, A_CYC_HI, A_STALL, A_BUBBLE, A_ISSUED, A_REJECT, A_FP_OVF, A_FP_UNF, A_FP_INV,
            A_FP_STAT, A_LAG, A_FETCH, A_KEEP_D, A_KEEP_S: return 1'b1;
            default:   return a[2:0] == 3'd4 && ((a >= A_NBODY + ADDR_W'(4) && a <= A_OPT + ADDR_W'(4))
                                                 || a == A_LAG + ADDR_W'(4) || a == A_FETCH + ADDR_W'(4)
                                                 || a == A_KEEP_D + ADDR_W'(4) || a == A_KEEP_S + ADDR_W'(4));
        endcase
    endfunction

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
    logic w_unmapped;   // the write being answered went to an unmapped address
    always_ff @(posedge ap_clk) begin
        if (w_hs) w_unmapped <= !mapped(waddr);
    end
    assign s_axi_control_AWREADY = (wstate == WR_IDLE);
    assign s_axi_control_WREADY  = (wstate == WR_DATA);
    assign s_axi_control_BVALID  = (wstate == WR_RESP);
    assign s_axi_control_BRESP   = w_unmapped ? SLVERR : OKAY;

    // the fp_status bits of a word, in the order of fp_set / int_fp_flags: {invalid, underflow, overflow}
    function automatic logic [2:0] fp_bits(input logic [31:0] word);
        return {word[FP_INVALID_FLAG_BIT], word[FP_UNDERFLOW_FLAG_BIT], word[FP_OVERFLOW_FLAG_BIT]};
    endfunction

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

    // ---------------- control / interrupt registers ----------------
    logic        int_ap_start, int_auto_restart, int_ap_done, int_ap_ready, int_gie;
    logic [1:0]  int_ier, int_isr;
    logic [15:0] int_err_flags;   // codes 1..16 (bit k-1)
    logic [7:0]  int_err_code;
    logic [2:0]  int_fp_flags;

    wire wr_ctrl   = w_hs && (waddr == A_AP_CTRL);
    wire rd_ctrl   = ar_hs && (raddr == A_AP_CTRL);
    // errors of this module: code 8 ap_start while a run is pending or busy, code 9 unmapped address
    wire start_busy = wr_ctrl && wstrb4[0] && wdata32[AP_START_BIT] && (int_ap_start || !ap_idle);
    wire unmapped   = (w_hs && !mapped(waddr)) || (ar_hs && !mapped(raddr));
    wire [15:0] flags_set = {7'd0, unmapped, start_busy || err_set[7], err_set[6:0]};
    wire [7:0]  code_set  = unmapped ? 8'(ERR_UNMAPPED) : (start_busy ? 8'(ERR_START_WHILE_BUSY) : err_code);

    always_ff @(posedge ap_clk) begin
        if (rst) begin
            int_ap_start     <= 1'b0;
            int_auto_restart <= 1'b0;
            int_ap_done      <= 1'b0;
            int_ap_ready     <= 1'b0;
            int_gie          <= 1'b0;
            int_ier          <= 2'b00;
            int_isr          <= 2'b00;
            int_err_flags    <= 16'h0000;
            int_err_code     <= 8'h00;
            int_fp_flags     <= 3'b000;
        end else begin
            // ap_start: set by a write of 1, cleared on the ap_ready handshake unless auto_restart
            if (wr_ctrl && wstrb4[0] && wdata32[AP_START_BIT]) int_ap_start <= 1'b1;
            else if (ap_ready) int_ap_start <= int_auto_restart;
            if (wr_ctrl && wstrb4[0]) int_auto_restart <= wdata32[AUTO_RESTART_BIT];
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
                logic [15:0] flags;
                flags = int_err_flags;
                if (w_hs && waddr == A_STATUS && wstrb4[0]) flags[7:0]  = flags[7:0] & ~wdata32[7:0];
                if (w_hs && waddr == A_STATUS && wstrb4[3]) flags[15:8] = flags[15:8] & ~wdata32[31:24];
                if (flags == 16'h0000) int_err_code <= 8'h00;
                if (flags_set != 16'h0000 && (flags == 16'h0000)) int_err_code <= code_set;
                int_err_flags <= flags | flags_set;
            end
            // fp_status: sticky event flags, write 1 to clear (a new event in the same cycle wins)
            if (w_hs && waddr == A_FP_STAT && wstrb4[0]) int_fp_flags <= (int_fp_flags & ~fp_bits(wdata32)) | fp_set;
            else int_fp_flags <= int_fp_flags | fp_set;
        end
    end
    assign ap_start  = int_ap_start;
    assign interrupt = int_gie && (int_isr != 2'b00);

    // ---------------- argument registers (not reset: written by the host before ap_start) ----------
    logic [31:0] r_num_bodies, r_num_manifolds, r_iterations, r_dt, r_gx, r_gy, r_gz, r_damping, r_options, r_lag,
                 r_fetch, r_keep_d, r_keep_s;
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
            r_lag           <= '0;
            r_fetch         <= '0;
            r_keep_d        <= '0;
            r_keep_s        <= '0;
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
                A_LAG:   r_lag           <= merge(r_lag, wdata32, wstrb4);
                A_FETCH: r_fetch         <= merge(r_fetch, wdata32, wstrb4);
                A_KEEP_D: r_keep_d       <= merge(r_keep_d, wdata32, wstrb4);
                A_KEEP_S: r_keep_s       <= merge(r_keep_s, wdata32, wstrb4);
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
    assign lag           = r_lag;
    assign fetch_passes  = r_fetch;
    assign keep_dyn      = r_keep_d;
    assign keep_static   = r_keep_s;

    // ---------------- read data (registered at the AR handshake) ----------------
    logic [31:0] rmux;
    always_comb begin
        unique case (raddr)
            A_AP_CTRL: begin
                rmux = 32'd0;
                rmux[AP_START_BIT]     = int_ap_start;
                rmux[AP_DONE_BIT]      = int_ap_done;
                rmux[AP_IDLE_BIT]      = ap_idle;
                rmux[AP_READY_BIT]     = int_ap_ready;
                rmux[AUTO_RESTART_BIT] = int_auto_restart;
                rmux[AP_INTERRUPT_BIT] = interrupt;
            end
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
            A_LAG:     rmux = r_lag;
            A_FETCH:   rmux = r_fetch;
            A_KEEP_D:  rmux = r_keep_d;
            A_KEEP_S:  rmux = r_keep_s;
            A_STATUS:  rmux = {int_err_flags[15:8], 8'd0, int_err_code, int_err_flags[7:0]};
            A_CYC_LO:  rmux = stat_cycles[31:0];
            A_CYC_HI:  rmux = stat_cycles[63:32];
            A_STALL:   rmux = stat_stalls;
            A_BUBBLE:  rmux = stat_bubbles;
            A_ISSUED:  rmux = stat_issued;
            A_REJECT:  rmux = stat_rejected;
            A_FP_OVF:  rmux = stat_fp_overflow;
            A_FP_UNF:  rmux = stat_fp_underflow;
            A_FP_INV:  rmux = stat_fp_invalid;
            A_FP_STAT: begin
                rmux = 32'd0;
                rmux[FP_OVERFLOW_FLAG_BIT]  = int_fp_flags[0];
                rmux[FP_UNDERFLOW_FLAG_BIT] = int_fp_flags[1];
                rmux[FP_INVALID_FLAG_BIT]   = int_fp_flags[2];
            end
            default:   rmux = 32'd0;
        endcase
    end
    always_ff @(posedge ap_clk) begin
        if (ar_hs) begin
            s_axi_control_RDATA <= DATA_W'(rmux);
            s_axi_control_RRESP <= mapped(raddr) ? OKAY : SLVERR;
        end
    end
endmodule

`default_nettype wire
