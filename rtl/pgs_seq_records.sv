// pgs_seq_records: the constraint records pgs_sequencer offers to the issue, and what it checks of them at once.
//
// WINDOW = 0 (the streaming kernel): the records of every pass from s_cons in schedule order (pgs_record_asm: a
// record of the pass kind's beats, tagged with its kind), one lane; pass `pass`, slot `slot` of the record offered.
// TLAST rules (rtl/README.md "Bad input", err_tlast = code 0x01): TLAST before a pass's last record ends the pass
// there and the missing slots are offered as `fill` (rejected, one a cycle); a pass's last record without TLAST
// discards the beats up to the next TLAST (`flush`). WINDOW > 0 (the window kernel): pgs_window's ring, each record
// (LANES slots' combined records) streamed once per fetch and offered to the passes of the fetch, the lanes' heads
// (body indices and the checks that depend only on the record) read when offered and their words in the cycle after
// the take (the ring's registered read); with the impulses in the records each head also carries whether its slot
// was rejected in an earlier fetch (w_rej_q, read from the issue's rejected-slot flags as the record is written).
//
// Per lane of the record offered (rec_valid; rec_kind its pass kind; rec_trunc a record cut short by TLAST): body
// indices la / lb, l_sd the header's spin damping, l_empty_hdr an empty lane (header all ones, the window kernel's
// padding), l_index a bad body index (>= nb, or the same body twice), l_nonfinite a non-finite word of its kind's,
// l_fa / l_fb / l_lin a shock pass's header bits (streaming kernel only). l_words: the pass kind's words for the
// lane's stage 1: the streaming kernel's at the record offered (the lane registers them at issue), the window
// kernel's of the record taken in the previous cycle, viewed as s1_kind (the ring's registered read). `slot_step`
// (from the issue: the record was taken, or a fill slot passed) steps the pass and slot.
// Window kernel only: w_addr the candidate's ring address, w_first / w_lastg its pass is the first / last of its
// fetch; w_asm_move / w_asm_slot the record entering the ring (written the next cycle).
`default_nettype none

module pgs_seq_records #(
    parameter int EXP_BITS         = 8,
    parameter int MAN_BITS         = 23,
    parameter int MAX_BODIES       = 65536,
    parameter int CONS_W           = 512,
    parameter int WINDOW           = 0,
    parameter int WINDOW_CTX       = 8,
    parameter int LANES            = 1,
    parameter bit IMPULSES_IN_RECORDS = 1'b0,
    parameter int MU_W             = 0,
    parameter bit TANGENTS_ON_CHIP = 1'b0,
    localparam int W               = 1 + EXP_BITS + MAN_BITS,
    localparam int IDX_W           = $clog2(MAX_BODIES),
    localparam int ITER_W          = pgs_seq_pkg::ITER_W,
    localparam int S1_WORDS        = pgs_seq_pkg::stage_words(MU_W, TANGENTS_ON_CHIP, IMPULSES_IN_RECORDS),
    localparam int RA_W            = WINDOW > 1 ? $clog2(WINDOW) : 1
) (
    input  wire logic                        clk,
    input  wire logic                        rst,
    input  wire logic                        init,        // the sequencer idle: the next step starts afresh
    input  wire logic                        first_start, // window kernel: the step started next has passes and
                                                          // records (from the run's arguments: pgs_window)
    input  wire logic                        fetch_en,    // LOAD and SOLVE: records are assembled
    input  wire logic [31:0]                 nb,
    input  wire logic [31:0]                 nm,          // slots per pass (a multiple of LANES)
    input  wire logic [ITER_W:0]             iters,
    input  wire logic [ITER_W:0]             passes,
    input  wire logic                        ilv,         // contact and friction passes interleaved
    input  wire logic [31:0]                 lag,         // window kernel: slots a pass trails the one before
    input  wire logic [31:0]                 fetch,       // window kernel: passes a fetch serves
    input  wire logic [CONS_W-1:0]           s_cons_tdata,
    input  wire logic                        s_cons_tvalid,
    output logic                             s_cons_tready,
    input  wire logic                        s_cons_tlast,
    output logic                             rec_valid,
    output logic                             rec_kind,
    output logic                             rec_trunc,
    output logic [ITER_W:0]                  pass,
    output logic [31:0]                      slot,        // the record's index within its pass (slot of lane 0 / LANES)
    output logic                             slot_last,   // ... the pass's last
    output logic                             fill,
    output logic                             flush,
    output logic                             err_tlast,
    output logic [LANES*IDX_W-1:0]           la,
    output logic [LANES*IDX_W-1:0]           lb,
    output logic [LANES-1:0]                 l_sd,
    output logic [LANES-1:0]                 l_empty_hdr,
    output logic [LANES-1:0]                 l_index,
    output logic [LANES-1:0]                 l_nonfinite,
    output logic [LANES-1:0]                 l_fa,
    output logic [LANES-1:0]                 l_fb,
    output logic [LANES-1:0]                 l_lin,
    output logic [LANES*S1_WORDS*W-1:0]      l_words,
    input  wire logic                        s1_kind,
    input  wire logic                        take,
    input  wire logic                        slot_step,
    output logic [RA_W-1:0]                  w_addr,
    output logic                             w_first,
    output logic                             w_lastg,
    output logic                             w_asm_move,
    output logic [31:0]                      w_asm_slot,
    output logic [LANES-1:0]                 w_head_seen,
    input  wire logic [LANES-1:0]            w_rej_q
);
    import pgs_seq_pkg::CONTACT, pgs_seq_pkg::FRICTION;
    localparam int LG_L     = $clog2(LANES);
    localparam int C_WORDS  = pgs_seq_pkg::contact_words(IMPULSES_IN_RECORDS);
    localparam int F_COEFF  = pgs_stream_layout_pkg::friction_words(MU_W, TANGENTS_ON_CHIP);  // words up to the impulses
    localparam int F_WORDS  = pgs_seq_pkg::friction_words(MU_W, TANGENTS_ON_CHIP, IMPULSES_IN_RECORDS);
    localparam int C_BEATS  = pgs_seq_pkg::record_beats(C_WORDS, W, CONS_W);   // contact record
    localparam int F_BEATS  = pgs_seq_pkg::record_beats(F_WORDS, W, CONS_W);   // friction record
    localparam int CM_BEATS = C_BEATS > F_BEATS ? C_BEATS : F_BEATS;
    // one lane's window record: the contact and friction words together (on-chip impulses), or with the impulses in
    // the records the record of its fetch's one pass kind (each fetch serves passes of one kind), padded to CM_BEATS
    localparam int WR_BEATS = IMPULSES_IN_RECORDS ? CM_BEATS : pgs_seq_pkg::record_beats(23 + F_COEFF, W, CONS_W);
    localparam int CREC_W   = CM_BEATS * CONS_W;
    localparam int CNEED_W  = $clog2(CM_BEATS + 1);
    localparam int LREC_W   = WR_BEATS * CONS_W;  // one lane's window record
    localparam int HB_W     = 2 * IDX_W + 5;      // head_of: what a lane's record gives its head
    // one lane's head in the window's ring: with the impulses in the records also whether its slot was rejected in
    // an earlier fetch (read from the rejected-slot flags as the record is written)
    localparam int HL_W     = HB_W + (IMPULSES_IN_RECORDS ? 1 : 0);

    // the full body indices of a header: out of range, or the same body twice
    localparam int HIDX_W = pgs_stream_layout_pkg::HEADER_BODY_B_LSB + pgs_stream_layout_pkg::HEADER_BODY_B_BITS;
    function automatic logic index_bad(input logic [HIDX_W-1:0] hdr, input logic [31:0] n_bodies);
        logic [31:0] ha = hdr[31:0];
        logic [31:0] hb = 32'(hdr[pgs_stream_layout_pkg::HEADER_BODY_B_LSB +: pgs_stream_layout_pkg::HEADER_BODY_B_BITS]);
        return ha >= n_bodies || hb >= n_bodies || ha == hb;
    endfunction
    // a non-finite word (exponent all ones) in a record of pass kind k (the header, then the kind's words): the
    // contact record's 23 words, the friction record's F_WORDS (the impulses it carries included)
    function automatic logic nonfinite_of(input logic [CREC_W-1:0] r, input logic k);
        logic nf = 1'b0;
        for (int j = 0; j < 23; j++)
            if (j < F_WORDS || k == CONTACT) nf = nf || r[64 + j*W + MAN_BITS +: EXP_BITS] == '1;
        return nf;
    endfunction
    // the record of pass kind k in one lane's window record: the header, then the kind's words from bit 64 (with the
    // impulses in the records a fetch streams the records of its passes' one kind, so its words are there; else the
    // friction words follow the contact words)
    localparam int FRIC_AT = IMPULSES_IN_RECORDS ? 64 : 64 + 23 * W;
    /* verilator lint_off UNUSEDSIGNAL */  // r: the record's padding bits and the other kind's words
    function automatic logic [CREC_W-1:0] kind_view(input logic [LREC_W-1:0] r, input logic k);
        logic [CREC_W-1:0] v = '0;
        v[0 +: 64] = r[0 +: 64];
        if (k == FRICTION) v[64 +: F_WORDS*W] = r[FRIC_AT +: F_WORDS*W];
        else               v[64 +: C_WORDS*W] = r[64 +: C_WORDS*W];
        return v;
    endfunction
    /* verilator lint_on UNUSEDSIGNAL */
    // what the window keeps of a lane's record for the cycle it is offered: {non-finite as a friction record,
    // non-finite as a contact record, index_bad, empty lane (header all ones), spin damping, body B, body A}
    function automatic logic [HB_W-1:0] head_of(input logic [LREC_W-1:0] r, input logic [31:0] n_bodies);
        return {nonfinite_of(kind_view(r, FRICTION), FRICTION), nonfinite_of(kind_view(r, CONTACT), CONTACT),
                index_bad(r[HIDX_W-1:0], n_bodies), r[63:0] == '1, r[pgs_stream_layout_pkg::HEADER_SPIN_DAMP_BIT],
                r[32 +: IDX_W], r[IDX_W-1:0]};
    endfunction

    wire [31:0] nm_rec = nm >> LG_L;  // records per pass
    assign slot_last = slot == nm_rec - 1;

    generate
        if (WINDOW == 0) begin : g_stream
            logic [CREC_W-1:0] crec;
            logic [ITER_W:0] a_pass;   // pass of the record being assembled
            logic [31:0]     a_slot;
            wire             a_kind = pgs_seq_pkg::kind_of(a_pass, ilv, iters);
            wire             a_last = a_slot == nm - 1;
            logic            c_done, c_done_trunc, c_asm_ready, crec_last;
            pgs_record_asm #(.BEAT_W(CONS_W), .MAX_BEATS(CM_BEATS), .TAG_W(1)) u_cons_asm (
                .clk, .rst, .enable(fetch_en && a_pass < passes && nm != 0 && !flush),
                .need(a_kind ? CNEED_W'(F_BEATS) : CNEED_W'(C_BEATS)), .in_tag(a_kind),
                .s_tdata(s_cons_tdata), .s_tvalid(s_cons_tvalid), .s_tlast(s_cons_tlast), .s_tready(c_asm_ready),
                .done(c_done), .done_trunc(c_done_trunc), .rec_data(crec), .rec_tag(rec_kind), .rec_last(crec_last),
                .rec_trunc(rec_trunc), .rec_valid(rec_valid), .rec_ready(take));
            assign s_cons_tready = c_asm_ready || flush;
            wire c_pass_end = c_done && (a_last || s_cons_tlast);   // the assembler moves on to the next pass
            assign err_tlast = c_done && (s_cons_tlast != a_last || c_done_trunc);
            wire [63:0] hdr = crec[63:0];
            assign la          = hdr[IDX_W-1:0];
            assign lb          = hdr[32 +: IDX_W];
            assign l_sd        = hdr[pgs_stream_layout_pkg::HEADER_SPIN_DAMP_BIT];
            assign l_empty_hdr = 1'b0;
            assign l_index     = index_bad(hdr[HIDX_W-1:0], nb);
            assign l_nonfinite = nonfinite_of(crec, rec_kind);
            assign l_fa        = hdr[pgs_stream_layout_pkg::HEADER_FROZEN_A_BIT];
            assign l_fb        = hdr[pgs_stream_layout_pkg::HEADER_FROZEN_B_BIT];
            assign l_lin       = hdr[pgs_stream_layout_pkg::HEADER_SHOCK_LINEAR_BIT];
            assign l_words     = crec[64 +: S1_WORDS*W];
            assign w_addr      = '0;
            assign w_first     = 1'b0;
            assign w_lastg     = 1'b1;   // every pass writes its impulses out
            assign w_asm_move  = 1'b0;
            assign w_asm_slot  = '0;
            assign w_head_seen = '0;
            // the window's arguments and rejected flags, the records' padding, the stage's kind (the lane registers
            // the words at issue)
            wire unused_stream = ^{lag, fetch, crec[CREC_W-1:64 + S1_WORDS*W], w_rej_q, s1_kind, first_start};

            always_ff @(posedge clk) begin
                if (init) begin
                    a_pass <= '0;
                    a_slot <= '0;
                    flush  <= 1'b0;
                    pass   <= '0;
                    slot   <= '0;
                    fill   <= 1'b0;
                end else begin
                    if (c_done) begin
                        if (c_pass_end) begin
                            a_slot <= '0;
                            a_pass <= a_pass + 1'b1;
                        end else begin
                            a_slot <= a_slot + 1;
                        end
                    end
                    if (c_done && a_last && !s_cons_tlast) flush <= 1'b1;
                    else if (flush && s_cons_tvalid && s_cons_tlast) flush <= 1'b0;
                    if (slot_step) begin
                        if (slot_last) begin
                            slot <= '0;
                            pass <= pass + 1'b1;
                            fill <= 1'b0;
                        end else begin
                            slot <= slot + 1;
                            if (take && crec_last) fill <= 1'b1;   // TLAST before the pass's last slot
                        end
                    end
                end
            end
        end else begin : g_window
            logic [LANES*LREC_W-1:0] wr_rec, rd_rec;
            logic [LANES*HL_W-1:0]   wr_head, whead;
            logic              w_done, w_asm_first;
            logic [$clog2(WINDOW)-1:0] cand_addr;
            logic [ITER_W+1:0] w_start_pass;   // the pass the window starts next, and its kind (rec_kind: the
                                               // candidate's, kept with its pass context)
            pgs_window #(.CONS_W(CONS_W), .REC_BEATS(LANES * WR_BEATS), .DEPTH(WINDOW), .CTX(WINDOW_CTX),
                         .PASS_W(ITER_W + 1), .HEAD_W(LANES * HL_W)) u_window (
                .clk, .rst, .init, .first_start, .nm(nm_rec), .passes, .fetch_passes(fetch[ITER_W:0]),
                .lag, .fetch_en, .s_tdata(s_cons_tdata),
                .s_tvalid(s_cons_tvalid), .s_tready(s_cons_tready), .s_tlast(s_cons_tlast), .asm_move(w_asm_move),
                .asm_slot(w_asm_slot), .asm_first(w_asm_first), .wr_rec, .wr_head,
                .cand_valid(rec_valid), .cand_head(whead), .cand_addr, .cand_first(w_first), .cand_lastg(w_lastg),
                .cand_trunc(rec_trunc), .rd_rec, .cand_pass(pass), .start_pass_no(w_start_pass),
                .start_kind(pgs_seq_pkg::kind_of(w_start_pass[ITER_W:0], ilv, iters)), .cand_kind(rec_kind),
                .cand_slot(slot), .take,
                .all_done(w_done), .flushing(flush), .tlast_err(err_tlast));
            assign w_addr = RA_W'(cand_addr);
            logic w_first_q;   // the record being written belongs to the first fetch
            always_ff @(posedge clk) begin
                if (w_asm_move) w_first_q <= w_asm_first;
            end
            always_comb begin
                for (int l = 0; l < LANES; l++) begin
                    automatic logic [HL_W-1:0] h = whead[l*HL_W +: HL_W];
                    // (the seen bit: of a later fetch only; its read is the registered one of the record's move)
                    wr_head[l*HL_W +: HL_W] = HL_W'({w_rej_q[l] && !w_first_q, head_of(wr_rec[l*LREC_W +: LREC_W], nb)});
                    w_head_seen[l] = IMPULSES_IN_RECORDS && h[HL_W-1];
                    la[l*IDX_W +: IDX_W] = h[IDX_W-1:0];
                    lb[l*IDX_W +: IDX_W] = h[IDX_W +: IDX_W];
                    l_sd[l]        = h[2*IDX_W];
                    l_empty_hdr[l] = h[2*IDX_W + 1];
                    l_index[l]     = h[2*IDX_W + 2];
                    l_nonfinite[l] = rec_kind == FRICTION ? h[2*IDX_W + 4] : h[2*IDX_W + 3];
                    // stage 1: the words of the record taken in the issue cycle (the ring's registered read)
                    l_words[l*S1_WORDS*W +: S1_WORDS*W] = kind_view(rd_rec[l*LREC_W +: LREC_W], s1_kind)[64 +: S1_WORDS*W];
                end
            end
            assign l_fa     = '0;
            assign l_fb     = '0;
            assign l_lin    = '0;
            assign fill     = 1'b0;
            // the window ends the solve with the last pass's last record (the sequencer's solve_last); the padding of
            // the lanes' records, its all-done flag, the step's slot stepping (the window's own) are not needed here
            logic unused_window;
            always_comb begin
                unused_window = ^{w_done, fetch[31:ITER_W+1], slot_step, w_start_pass[ITER_W+1]};
                for (int l = 0; l < LANES; l++)
                    unused_window ^= ^kind_view(rd_rec[l*LREC_W +: LREC_W], s1_kind)[CREC_W-1:64 + S1_WORDS*W];
            end
        end
    endgenerate
endmodule

`default_nettype wire
