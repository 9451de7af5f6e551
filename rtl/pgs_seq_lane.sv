// pgs_seq_lane: one issue lane of pgs_sequencer, from the issue of a manifold-pass to its retire.
//
// Issue cycle t (`issue`): bodies A and B are read from the body RAM (the sequencer's ports 2 LANE and 2 LANE + 1,
// back as ra / rb at t + 1) and the impulses the pass starts from: the impulse RAM bank of the lane (on-chip impulses,
// by record index `slot`; zeros in a step's first pass of a kind), or the record's own impulse words (IMPULSES_IN_RECORDS;
// in the window kernel the later passes of a fetch read what the pass before wrote into the lane's impulse ring at the
// record's ring address w_addr). Stage 1 (t + 1) feeds the lane's datapath (pgs_lane_datapath) with the pass kind's
// record words (`words`: the streaming kernel's registered at issue, the window kernel's the ring's registered read),
// the impulses and the bodies' words. A shock pass's row (header bits frozen A / B, linear: the streaming kernel only)
// takes its frozen body as a static one (its inverse mass and inertia enter as 0, its tag's dynamic bit is clear, so
// retire does not write it) and a linear row's inverse inertias as 0, spin damping off. Retire (t + 1 + LATENCY): the
// tag gives back the slot, iteration, bodies and whether each is written (dynamic and not frozen), the ring address
// and whether the pass is the last of its fetch; the impulses are written to the lane's impulse RAM bank or ring.
`default_nettype none

module pgs_seq_lane #(
    parameter int EXP_BITS         = 8,
    parameter int MAN_BITS         = 23,
    parameter int MAX_BODIES       = 65536,
    parameter int MAX_MANIFOLDS    = 262144,
    parameter int WINDOW           = 0,
    parameter int LANES            = 1,
    parameter int IINV_W           = 3,
    parameter bit IMPULSES_IN_RECORDS = 1'b0,
    parameter int MU_W             = 0,
    parameter bit TANGENTS_ON_CHIP = 1'b0,
    parameter bit SOFT_CONTACT     = 1'b0,
    parameter bit SHARED_DATAPATH  = 1'b1,
    parameter int DELAY_BLOCK_MIN_DEPTH = 0,
    parameter bit ADD_SHIFT_DSP = 1'b0,   // the datapath's fp_add instances in their DSP48E2 form
    localparam int W               = 1 + EXP_BITS + MAN_BITS,
    localparam int IDX_W           = $clog2(MAX_BODIES),
    localparam int SLOT_W          = $clog2(MAX_MANIFOLDS),
    localparam int ITER_W          = pgs_seq_pkg::ITER_W,
    localparam int EV_W            = pgs_seq_pkg::EV_W,
    localparam int BREC_W          = (14 + IINV_W) * W,
    localparam int S1_WORDS        = pgs_seq_pkg::stage_words(MU_W, TANGENTS_ON_CHIP, IMPULSES_IN_RECORDS),
    localparam int RA_W            = WINDOW > 1 ? $clog2(WINDOW) : 1
) (
    input  wire logic                  clk,
    input  wire logic                  rst,
    input  wire logic                  issue,
    input  wire logic                  kind,        // the issuing record's pass kind (read at issue)
    input  wire logic                  s1_kind,     // stage 1's pass kind (the issue before)
    input  wire logic [ITER_W-1:0]     iter,
    input  wire logic [31:0]           slot,        // the record index (slot of lane 0 / LANES)
    input  wire logic [SLOT_W-1:0]     lslot,       // this lane's manifold slot
    input  wire logic [IDX_W-1:0]      la,
    input  wire logic [IDX_W-1:0]      lb,
    input  wire logic                  dyn_a,
    input  wire logic                  dyn_b,
    input  wire logic                  sd,          // the header's spin damping
    input  wire logic                  fa,          // a shock pass's header bits: body A / B frozen, a linear row
    input  wire logic                  fb,
    input  wire logic                  lin,
    input  wire logic [S1_WORDS*W-1:0] words,
    input  wire logic [RA_W-1:0]       w_addr,
    input  wire logic                  w_first,
    input  wire logic                  w_lastg,
    input  wire logic [BREC_W-1:0]     ra,          // bodies A and B read at issue
    input  wire logic [BREC_W-1:0]     rb,
    input  wire logic                  soft_on,     // SOFT_CONTACT: the run's options bit and keep factors
    input  wire logic [W-1:0]          keep_dyn,
    input  wire logic [W-1:0]          keep_static,
    output logic                       retire,
    output logic                       r_kind,
    output logic      [4*W-1:0]        r_imp,       // contact: lam[0..3]; friction: lamT[0..1], two zero words
    output logic      [12*W-1:0]       r_vel,       // vA wA vB wB
    output logic      [IDX_W-1:0]      r_a,
    output logic      [IDX_W-1:0]      r_b,
    output logic                       r_write_a,   // body A / B is written (dynamic, not frozen)
    output logic                       r_write_b,
    output logic      [SLOT_W-1:0]     r_slot,
    output logic      [ITER_W-1:0]     r_iter,
    output logic      [RA_W-1:0]       r_addr,      // window kernel: the ring address
    output logic                       r_lastg,     // ... its pass is the last of its fetch
    output logic      [3*EV_W-1:0]     r_ev         // {invalid, underflow, overflow} of the lane's datapath
);
    import pgs_seq_pkg::CONTACT, pgs_seq_pkg::FRICTION;
    localparam int LG_L    = $clog2(LANES);
    localparam int BSLOT_W = $clog2(MAX_MANIFOLDS / LANES);
    localparam int F_COEFF = pgs_stream_layout_pkg::friction_words(MU_W, TANGENTS_ON_CHIP);  // words up to the impulses
    // the window kernel with the impulses in the records: the tag also carries the ring address and whether the pass
    // is the last of its fetch (the impulse ring's write, the impulse-out record)
    localparam int WTAG_W  = WINDOW > 0 && IMPULSES_IN_RECORDS ? RA_W + 1 : 0;
    localparam int STAG_W  = WTAG_W + SLOT_W + ITER_W + 2 * IDX_W + 2;

    logic [4*W-1:0]        rd_lam;
    logic [2*W-1:0]        rd_lamT;
    logic                  s1_valid, s1_sd, s1_fa, s1_fb, s1_lin;
    logic [S1_WORDS*W-1:0] s1_words;
    logic [STAG_W-1:0]     s1_tag, tag;
    logic [EV_W-1:0]       ev_ovf, ev_unf, ev_inv;

    if (IMPULSES_IN_RECORDS) begin : g_imp_rec
        // the impulses the pass starts from are the record's last words (host-given or the last pass's). The window
        // kernel's record serves every pass of its fetch (of one kind): the fetch's first pass reads the record's,
        // every later pass what the pass before wrote into the impulse ring (the ring address's lam[0..3] after a
        // contact pass, lamT[0..1] after a friction pass: read at issue, written at retire, a record of a later pass
        // issuing only after that retire); a friction pass's lam (its friction limit, the contact passes' result) is
        // the record's.
        logic [4*W-1:0] rec_lam;
        logic [2*W-1:0] rec_lamT, ring_lamT;
        logic [4*W-1:0] ring_imp;   // the impulse ring's word at the issue's ring address (window kernel)
        logic           s1_first;   // stage 1's pass is the first of its fetch (window kernel)
        assign rec_lam  = s1_kind == CONTACT ? s1_words[pgs_stream_layout_pkg::CONTACT_LAM_WORD*W +: 4*W]
                                             : s1_words[F_COEFF*W +: 4*W];
        assign rec_lamT = s1_words[(F_COEFF + pgs_stream_layout_pkg::FRICTION_LAMT_AFTER_LAM)*W +: 2*W];
        assign ring_lamT = ring_imp[0 +: 2*W];
        if (WINDOW > 0) begin : g_imp_ring
            pgs_ring_ram #(.WIDTH(4*W), .DEPTH(WINDOW), .SYNC_READ(1'b1)) u_imp_ring (
                .clk, .wr_en(retire), .wr_addr(r_addr), .wr_data(r_imp), .rd_en(issue), .rd_addr(w_addr),
                .rd_data(ring_imp));
            always_ff @(posedge clk) begin
                if (issue) s1_first <= w_first;
            end
        end else begin : g_no_imp_ring
            assign ring_imp = '0;
            assign s1_first = 1'b1;
            wire unused_ring_addr = ^{w_addr, w_first};
        end
        assign rd_lam  = s1_kind == CONTACT && !s1_first ? ring_imp : rec_lam;
        assign rd_lamT = s1_first ? rec_lamT : ring_lamT;
        wire unused_ring = ^{ring_imp[4*W-1:2*W], kind, iter == '0, slot};
    end else begin : g_imp_ram
        // lane l holds the slots l, l + LANES, ...: its impulse RAM bank is indexed by the record index
        wire [BSLOT_W-1:0] wr_rec = BSLOT_W'(r_slot >> LG_L);
        pgs_impulse_ram #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .MAX_MANIFOLDS(MAX_MANIFOLDS / LANES)) u_imp_ram (
            .clk, .rd_addr(slot[BSLOT_W-1:0]), .rd_zero_lam(kind == CONTACT && iter == '0),
            .rd_zero_lamT(kind == FRICTION && iter == '0), .rd_lam, .rd_lamT, .wr_addr(wr_rec),
            .wr_lam_en(retire && r_kind == CONTACT), .wr_lam(r_imp),
            .wr_lamT_en(retire && r_kind == FRICTION), .wr_lamT(r_imp[0 +: 2*W]));
        wire unused_imp_ram = ^{w_addr, w_first, slot[31:BSLOT_W]};
    end

    // stage 1: the record and tag of the manifold issued in the previous cycle
    always_ff @(posedge clk) begin
        if (rst) s1_valid <= 1'b0;
        else     s1_valid <= issue;
    end
    always_ff @(posedge clk) begin
        if (issue) begin
            s1_sd  <= sd && !lin;
            s1_fa  <= fa;
            s1_fb  <= fb;
            s1_lin <= lin;
            s1_tag <= STAG_W'({w_lastg, w_addr, lslot, iter, la, lb, dyn_a && !fa, dyn_b && !fb});
        end
    end
    // the pass kind's words: the streaming kernel registers the record at issue, the window kernel's ring read of the
    // record taken at issue is registered already
    if (WINDOW == 0) begin : g_s1_words
        always_ff @(posedge clk) begin
            if (issue) s1_words <= words;
        end
    end else begin : g_s1_ring
        assign s1_words = words;
    end

    // the bodies' mass words as the datapath takes them: 0 for a frozen body, no inverse inertia on a linear row
    wire [W-1:0]        m_a = s1_fa ? '0 : ra[13*W +: W];
    wire [W-1:0]        m_b = s1_fb ? '0 : rb[13*W +: W];
    wire [IINV_W*W-1:0] i_a = s1_fa || s1_lin ? '0 : ra[14*W +: IINV_W*W];
    wire [IINV_W*W-1:0] i_b = s1_fb || s1_lin ? '0 : rb[14*W +: IINV_W*W];
    pgs_lane_datapath #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .TAG_W(STAG_W), .IINV_W(IINV_W), .MU_W(MU_W),
                        .TANGENTS_ON_CHIP(TANGENTS_ON_CHIP), .SOFT_CONTACT(SOFT_CONTACT),
                        .SHARED_DATAPATH(SHARED_DATAPATH), .ALIGN(WINDOW > 0),
                        .DELAY_BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH), .ADD_SHIFT_DSP(ADD_SHIFT_DSP)) u_datapath (
        .clk, .rst, .in_valid(s1_valid), .in_kind(s1_kind), .in_tag(s1_tag), .in_rec(s1_words[0 +: 23*W]),
        .in_lam(rd_lam), .in_lamT(rd_lamT), .in_xa(ra[0 +: 3*W]), .in_xb(rb[0 +: 3*W]), .in_vwa(ra[7*W +: 6*W]),
        .in_vwb(rb[7*W +: 6*W]), .in_ma(m_a), .in_mb(m_b), .in_ia(i_a), .in_ib(i_b), .in_spin_damp(s1_sd),
        .in_soft(soft_on), .in_keep_dyn(keep_dyn), .in_keep_static(keep_static), .out_valid(retire),
        .out_kind(r_kind), .out_tag(tag), .out_imp(r_imp), .out_vel(r_vel), .ev_overflow(ev_ovf),
        .ev_underflow(ev_unf), .ev_invalid(ev_inv));

    // retire: the fields of the tag
    assign r_write_b = tag[0];
    assign r_write_a = tag[1];
    assign r_b       = tag[2 +: IDX_W];
    assign r_a       = tag[2 + IDX_W +: IDX_W];
    assign r_iter    = tag[2 + 2*IDX_W +: ITER_W];
    assign r_slot    = tag[2 + 2*IDX_W + ITER_W +: SLOT_W];
    if (WTAG_W > 0) begin : g_rtag_window
        assign r_addr  = tag[2 + 2*IDX_W + ITER_W + SLOT_W +: RA_W];
        assign r_lastg = tag[STAG_W-1];
    end else begin : g_rtag_stream
        assign r_addr  = '0;
        assign r_lastg = 1'b1;   // the streaming kernel: every pass writes its impulses out
    end
    assign r_ev = {ev_inv, ev_unf, ev_ovf};
    // body B's orientation, the bodies' positions and orientations past xA / xB: not read here
    wire unused_lane = ^{ra[7*W-1:3*W], rb[7*W-1:3*W]};
endmodule

`default_nettype wire
