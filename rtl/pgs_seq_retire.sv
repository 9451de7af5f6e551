// pgs_seq_retire: what leaves pgs_sequencer as its manifold-passes retire: the trace port and the impulse-out stream.
//
// Trace (TRACE = 1): per lane, in the cycle it retires (trace_valid bit l), the record of models/kernel/stream_format.py:
// words 0..15 the impulses (contact: lam[0..3]; friction: lamT[0..1], two zero words) and vA, wA, vB, wB, then the slot
// (32 bits), the iteration (16 bits) and the pass kind (1 bit), 15 zero bits.
// Impulse-out stream (IMPULSES_IN_RECORDS = 1, m_imp): one record per slot of every pass (the window kernel: of the last
// pass of every fetch, one record per window record, its lanes' words one after the other), in slot order, TLAST on
// each pass's last slot: the updated impulses of a retired manifold-pass, all zeros for a rejected slot or lane and an
// empty lane. The order FIFO takes every such slot at its step ({last, rejected}: slot_step with w_lastg), the data
// FIFO every such retire; a record leaves when its order entry is at the head and, unless rejected, its retire has
// arrived. A slot is taken only with room in the order FIFO (`imp_room`; the pipes have no backpressure), so a stalled
// stream stalls the issue. `imp_idle`: no impulse-out record pending (DONE waits for it).
`default_nettype none

module pgs_seq_retire #(
    parameter int EXP_BITS       = 8,
    parameter int MAN_BITS       = 23,
    parameter int MAX_MANIFOLDS  = 262144,
    parameter int LANES          = 1,
    parameter bit TRACE          = 1'b1,
    parameter bit IMPULSES_IN_RECORDS = 1'b0,
    parameter int IMP_FIFO_DEPTH = 256,
    localparam int W             = 1 + EXP_BITS + MAN_BITS,
    localparam int SLOT_W        = $clog2(MAX_MANIFOLDS),
    localparam int ITER_W        = pgs_seq_pkg::ITER_W,
    localparam int TRACE_W       = 16 * W + 64,
    localparam int IMP_OUT_W     = (LANES * 4 * W + 7) / 8 * 8
) (
    input  wire logic                        clk,
    input  wire logic                        rst,
    input  wire logic                        slot_step,   // a slot of the record offered is done
    input  wire logic                        slot_last,   // ... the pass's last
    input  wire logic                        w_lastg,     // ... its pass writes its impulses out
    input  wire logic                        issue,       // ... it issued (else it was rejected)
    input  wire logic [LANES-1:0]            l_retire,
    input  wire logic [LANES-1:0]            l_kind,
    input  wire logic [LANES-1:0]            l_lastg,     // the retiring pass writes its impulses out
    input  wire logic [LANES*4*W-1:0]        l_imp,
    input  wire logic [LANES*12*W-1:0]       l_vel,
    input  wire logic [LANES*SLOT_W-1:0]     l_slot,
    input  wire logic [LANES*ITER_W-1:0]     l_iter,
    output logic                             imp_room,
    output logic                             imp_idle,
    output logic      [IMP_OUT_W-1:0]        m_imp_tdata,
    output logic                             m_imp_tvalid,
    input  wire logic                        m_imp_tready,
    output logic                             m_imp_tlast,
    output logic      [LANES-1:0]            trace_valid,
    output logic      [LANES*TRACE_W-1:0]    trace_data
);
    generate
        if (IMPULSES_IN_RECORDS) begin : g_imp_out
            logic [1:0]           ord_head;
            logic [LANES*4*W-1:0] dat_head, dat_in;
            logic                 ord_empty, ord_full, dat_empty, dat_full;
            wire                  imp_hs  = m_imp_tvalid && m_imp_tready;
            wire                  ord_rej = ord_head[0];
            always_comb begin
                for (int l = 0; l < LANES; l++) dat_in[l*4*W +: 4*W] = l_retire[l] ? l_imp[l*4*W +: 4*W] : '0;
            end
            pgs_fifo #(.DATA_W(2), .DEPTH(IMP_FIFO_DEPTH)) u_imp_order (
                .clk, .rst, .push(slot_step && w_lastg), .push_data({slot_last, !issue}), .pop(imp_hs),
                .head(ord_head), .empty(ord_empty), .full(ord_full));
            pgs_fifo #(.DATA_W(LANES*4*W), .DEPTH(IMP_FIFO_DEPTH)) u_imp_data (
                .clk, .rst, .push((l_lastg & l_retire) != '0), .push_data(dat_in),
                .pop(imp_hs && !ord_rej), .head(dat_head), .empty(dat_empty), .full(dat_full));
            assign m_imp_tvalid = !ord_empty && (ord_rej || !dat_empty);
            assign m_imp_tdata  = IMP_OUT_W'(ord_rej ? '0 : dat_head);
            assign m_imp_tlast  = ord_head[1];
            assign imp_room     = !ord_full;
            assign imp_idle     = ord_empty;
            wire unused_imp = dat_full;   // the data FIFO holds no more entries than the order FIFO
        end else begin : g_no_imp_out
            assign m_imp_tvalid = 1'b0;
            assign m_imp_tdata  = '0;
            assign m_imp_tlast  = 1'b0;
            assign imp_room     = 1'b1;
            assign imp_idle     = 1'b1;
            wire unused_imp = ^{clk, rst, m_imp_tready, slot_step, slot_last, w_lastg, issue, l_lastg};
        end

        if (TRACE) begin : g_trace
            always_comb begin
                trace_valid = l_retire;
                trace_data  = '0;
                for (int l = 0; l < LANES; l++) begin
                    trace_data[l*TRACE_W +: 4*W]            = l_imp[l*4*W +: 4*W];
                    trace_data[l*TRACE_W + 4*W +: 12*W]     = l_vel[l*12*W +: 12*W];
                    trace_data[l*TRACE_W + 16*W +: 32]      = 32'(l_slot[l*SLOT_W +: SLOT_W]);
                    trace_data[l*TRACE_W + 16*W + 32 +: 16] = l_iter[l*ITER_W +: ITER_W];
                    trace_data[l*TRACE_W + 16*W + 48]       = l_kind[l];
                end
            end
        end else begin : g_no_trace
            assign trace_valid = '0;
            assign trace_data  = '0;
            wire unused_trace = ^{l_kind, l_iter, l_slot, l_vel, l_imp};   // fields of the trace only
        end
    endgenerate
endmodule

`default_nettype wire
