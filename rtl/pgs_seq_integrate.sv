// pgs_seq_integrate: the INTEG phase of pgs_sequencer: every body in index order through pgs_integrate_pipe, out on
// m_body.
//
// While `active`, body rd_idx = 0, 1, ... is read from the body RAM (rd_en; the record comes back as rd_rec, rd_bad
// its bad flag, in the next cycle) and enters the integrate pipe with the run's dt, damping and gravity; a static body
// (inverse mass 0 after the flush to zero) or a bad one rides in the pipe's tag and comes out unchanged, its events not
// counted. A body issues only with a free credit of the output FIFO (OUT_FIFO_DEPTH bodies in the pipe or the FIFO),
// so the pipe, which has no backpressure, never overflows it. The FIFO's records leave as O_BEATS beats of m_body,
// TLAST on the last beat of body nb - 1. `done`: every body sent (nb = 0 included). ev_*: the integrate pipe's events.
// `init` (the sequencer idle) clears the counters for the next step.
`default_nettype none

module pgs_seq_integrate #(
    parameter int EXP_BITS       = 8,
    parameter int MAN_BITS       = 23,
    parameter int BODY_OUT_W     = 128,
    parameter int OUT_FIFO_DEPTH = 64,
    parameter int IINV_W         = 3,
    parameter int DELAY_BLOCK_MIN_DEPTH = 0,
    parameter bit ADD_SHIFT_DSP = 1'b0,   // the integrate pipe's fp_add instances in their DSP48E2 form
    localparam int W             = 1 + EXP_BITS + MAN_BITS,
    localparam int BREC_W        = (14 + IINV_W) * W,
    localparam int EV_W          = pgs_seq_pkg::EV_W
) (
    input  wire logic                  clk,
    input  wire logic                  rst,
    input  wire logic                  init,
    input  wire logic                  active,
    input  wire logic [31:0]           nb,
    input  wire logic [W-1:0]          dt,
    input  wire logic [W-1:0]          damping,
    input  wire logic [W-1:0]          gx,
    input  wire logic [W-1:0]          gy,
    input  wire logic [W-1:0]          gz,
    output logic      [31:0]           rd_idx,
    input  wire logic [BREC_W-1:0]     rd_rec,
    input  wire logic                  rd_bad,
    output logic      [BODY_OUT_W-1:0] m_body_tdata,
    output logic                       m_body_tvalid,
    input  wire logic                  m_body_tready,
    output logic                       m_body_tlast,
    output logic                       done,
    output logic      [EV_W-1:0]       ev_overflow,
    output logic      [EV_W-1:0]       ev_underflow,
    output logic      [EV_W-1:0]       ev_invalid
);
    localparam int OREC_W  = 13 * W;                                  // body-out record
    localparam int O_BEATS = (OREC_W + BODY_OUT_W - 1) / BODY_OUT_W;
    localparam int OBEAT_W = $clog2(O_BEATS + 1);
    localparam int ITAG_W  = 1 + OREC_W;                              // integrate pipe's tag

    logic [31:0] credits;        // bodies in the integrate pipe or in the output FIFO
    logic [31:0] out_cnt;        // body-out records completely sent
    logic [OBEAT_W-1:0] out_beat;
    wire  int_issue = active && rd_idx < nb && credits < 32'(OUT_FIFO_DEPTH);
    logic i1_valid;
    always_ff @(posedge clk) begin
        if (rst) i1_valid <= 1'b0;
        else     i1_valid <= int_issue;
    end
    // static (mInv == 0 after flush) and bad bodies pass through unchanged; their events are not counted
    wire i1_static = rd_rec[13*W + MAN_BITS +: EXP_BITS] == '0 || rd_bad;
    wire [18*W-1:0] i_in = {gz, gy, gx, damping, dt, rd_rec[0 +: OREC_W]};
    logic              io_valid;
    logic [ITAG_W-1:0] io_tag;
    logic [OREC_W-1:0] io_data;
    pgs_integrate_pipe #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .TAG_W(ITAG_W),
                         .DELAY_BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH), .ADD_SHIFT_DSP(ADD_SHIFT_DSP)) u_integrate (
        .clk, .rst, .in_valid(i1_valid), .in_tag({i1_static, rd_rec[0 +: OREC_W]}), .in_data(i_in),
        .in_count(!i1_static), .out_valid(io_valid), .out_tag(io_tag), .out_data(io_data), .ev_overflow,
        .ev_underflow, .ev_invalid);

    logic [OREC_W-1:0] ofifo_head;
    logic ofifo_empty, ofifo_full;
    wire  out_hs   = m_body_tvalid && m_body_tready;
    wire  out_pop  = out_hs && out_beat == OBEAT_W'(O_BEATS - 1);
    pgs_fifo #(.DATA_W(OREC_W), .DEPTH(OUT_FIFO_DEPTH)) u_ofifo (
        .clk, .rst, .push(io_valid), .push_data(io_tag[OREC_W] ? io_tag[OREC_W-1:0] : io_data), .pop(out_pop),
        .head(ofifo_head), .empty(ofifo_empty), .full(ofifo_full));
    wire [O_BEATS*BODY_OUT_W-1:0] out_rec = (O_BEATS*BODY_OUT_W)'(ofifo_head);
    assign m_body_tvalid = !ofifo_empty;
    assign m_body_tdata  = out_rec[out_beat * BODY_OUT_W +: BODY_OUT_W];
    assign m_body_tlast  = out_beat == OBEAT_W'(O_BEATS - 1) && out_cnt == nb - 1;
    assign done          = (out_pop && out_cnt == nb - 1) || nb == 0 || out_cnt == nb;

    always_ff @(posedge clk) begin
        if (init) begin
            rd_idx   <= '0;
            credits  <= '0;
            out_cnt  <= '0;
            out_beat <= '0;
        end else begin
            if (int_issue) rd_idx <= rd_idx + 1;
            credits <= credits + 32'(int_issue) - 32'(out_pop);
            if (out_hs) out_beat <= out_pop ? '0 : out_beat + 1'b1;
            if (out_pop) out_cnt <= out_cnt + 1;
        end
    end

    // not needed: the FIFO never fills (a body issues only with a free credit); the body's inverse inertia words
    wire unused_integ = ^{ofifo_full, rd_rec};
endmodule

`default_nettype wire
