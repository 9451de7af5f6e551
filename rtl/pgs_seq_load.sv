// pgs_seq_load: the LOAD phase of pgs_sequencer: num_bodies body-in records from s_body, checked, to the body RAM.
//
// While `active` (the sequencer's LOAD phase) the records are assembled from s_body beats (pgs_record_asm, B_BEATS
// beats of BODY_IN_W bits a record) and each is written (wr_en, one a cycle at most) as body wr_idx = 0, 1, ...:
// wr_rec its words, wr_bad whether it is a *bad body* (rtl/README.md "Bad input"): a non-finite word (exponent all
// ones; err_nonfinite), a negative inverse mass or diagonal inverse inertia (sign set, exponent not zero; the
// off-diagonal words of the symmetric 3x3 may be negative; err_bad_mass), or a record cut short by TLAST. TLAST rules
// (err_tlast, code 0x02): an early TLAST (fewer bodies than nb) ends the stream there and the missing bodies are
// written as zero records, bad, one a cycle; a record cut short by TLAST is written bad; a missing TLAST on the last
// body (more beats) discards the beats up to the next TLAST. `done` is the cycle LOAD ends: the last body written
// and no beat left to discard. `init` (the sequencer idle) clears the counters for the next step.
// Latency: a record is written in the cycle after its last beat is taken.
`default_nettype none

module pgs_seq_load #(
    parameter int EXP_BITS  = 8,
    parameter int MAN_BITS  = 23,
    parameter int BODY_IN_W = 128,
    parameter int IINV_W    = 3,      // inverse-inertia words per body: 1 scalar, 3 diagonal, 6 symmetric 3x3
    localparam int W        = 1 + EXP_BITS + MAN_BITS,
    localparam int BREC_W   = (14 + IINV_W) * W
) (
    input  wire logic                 clk,
    input  wire logic                 rst,
    input  wire logic                 init,
    input  wire logic                 active,
    input  wire logic [31:0]          nb,
    input  wire logic [BODY_IN_W-1:0] s_body_tdata,
    input  wire logic                 s_body_tvalid,
    output logic                      s_body_tready,
    input  wire logic                 s_body_tlast,
    output logic                      wr_en,
    output logic [31:0]               wr_idx,
    output logic [BREC_W-1:0]         wr_rec,
    output logic                      wr_bad,
    output logic                      done,
    output logic                      err_tlast,
    output logic                      err_nonfinite,
    output logic                      err_bad_mass
);
    localparam int B_BEATS = (BREC_W + BODY_IN_W - 1) / BODY_IN_W;
    localparam int BNEED_W = $clog2(B_BEATS + 1);

    // b_end: a TLAST was taken (no more body beats this step); b_fill: after an early TLAST, the missing bodies are
    // written as zero records, bad, one per cycle; b_flush: after the last body without TLAST, beats are discarded up
    // to TLAST.
    logic [B_BEATS*BODY_IN_W-1:0] brec;
    logic        brec_valid, brec_last, brec_trunc, b_done, b_done_trunc, b_unused_tag, b_asm_ready;
    logic        b_end, b_fill, b_flush;
    logic [31:0] b_asm_cnt, load_idx;
    pgs_record_asm #(.BEAT_W(BODY_IN_W), .MAX_BEATS(B_BEATS), .TAG_W(1)) u_body_asm (
        .clk, .rst, .enable(active && b_asm_cnt < nb && !b_end), .need(BNEED_W'(B_BEATS)),
        .in_tag(1'b0), .s_tdata(s_body_tdata), .s_tvalid(s_body_tvalid), .s_tlast(s_body_tlast),
        .s_tready(b_asm_ready), .done(b_done), .done_trunc(b_done_trunc), .rec_data(brec), .rec_tag(b_unused_tag),
        .rec_last(brec_last), .rec_trunc(brec_trunc), .rec_valid(brec_valid), .rec_ready(1'b1));
    assign s_body_tready = b_asm_ready || b_flush;

    // checks of a body-in record (words: pos 0-2, q 3-6, v 7-9, w 10-12, mInv 13, IInv 14 .. 13 + IINV_W: the
    // scalar, the diagonal xx yy zz, or xx yy zz xy xz yz): a word is non-finite when its exponent is all ones,
    // negative when its sign is set and its exponent is not zero (a negative zero or subnormal reads as zero).
    // mInv and the diagonal words must not be negative; the off-diagonal words of the symmetric matrix may.
    localparam int SIGNED_FROM = 14 + (IINV_W < 3 ? IINV_W : 3);   // the first word that may be negative
    logic brec_nonfinite, brec_bad_mass;
    always_comb begin
        brec_nonfinite = 1'b0;
        brec_bad_mass  = 1'b0;
        for (int k = 0; k < 14 + IINV_W; k++) begin
            brec_nonfinite = brec_nonfinite || brec[k*W + MAN_BITS +: EXP_BITS] == '1;
            if (k >= 13 && k < SIGNED_FROM)
                brec_bad_mass = brec_bad_mass || (brec[k*W + W - 1] && brec[k*W + MAN_BITS +: EXP_BITS] != '0);
        end
    end
    wire load_last = wr_en && load_idx == nb - 1;
    wire b_early   = active && brec_valid && brec_last && load_idx != nb - 1;
    wire b_late    = active && brec_valid && !brec_last && load_idx == nb - 1;
    wire checked   = active && brec_valid && !brec_trunc;   // a whole record: its checks raise their errors
    assign wr_en         = active && (brec_valid || b_fill);
    assign wr_idx        = load_idx;
    assign wr_rec        = b_fill ? '0 : brec[0 +: BREC_W];
    assign wr_bad        = b_fill || brec_nonfinite || brec_bad_mass || brec_trunc;
    assign done          = active && (load_last || load_idx == nb) && !b_flush && !b_late;
    assign err_tlast     = b_done && (s_body_tlast != (b_asm_cnt == nb - 1) || b_done_trunc);
    assign err_nonfinite = checked && brec_nonfinite;
    assign err_bad_mass  = checked && brec_bad_mass;

    always_ff @(posedge clk) begin
        if (init) begin
            b_asm_cnt <= '0;
            load_idx  <= '0;
            b_end     <= 1'b0;
            b_fill    <= 1'b0;
            b_flush   <= 1'b0;
        end else begin
            if (b_done) b_asm_cnt <= b_asm_cnt + 1;
            if (b_done && s_body_tlast) b_end <= 1'b1;
            if (wr_en) load_idx <= load_idx + 1;
            if (b_early) b_fill <= 1'b1;
            else if (load_last) b_fill <= 1'b0;
            if (b_late) b_flush <= 1'b1;
            else if (b_flush && s_body_tvalid && s_body_tlast) b_flush <= 1'b0;
        end
    end

    // not needed: the assembler's tag (none), the padding bits of the last beat
    wire unused_load = ^{b_unused_tag, brec};
endmodule

`default_nettype wire
