// pgs_seq_issue: the record checks and the issue of pgs_sequencer: which lanes of the record offered issue, which are
// rejected, and whether the record is taken this cycle.
//
// Every lane of the record offered issues in the same cycle, or none does: the record is taken (`take`) in SOLVE when
// it is offered (rec_valid), is not a fill slot, the impulse-out stream has room (imp_room) and either no lane has to
// issue (all rejected or empty) or `may_issue` (from pgs_seq_hazards: no issuing lane's dynamic body in flight, the
// CAM not full, no drain or busy body bank). A lane is *empty* (the window kernel's padding: an all-ones header, never
// issued or rejected, no error) or *rejected* (consumed, never issued; rtl/README.md "Bad input") when it names a body
// out of range or the same body twice (l_index, code 0x04), holds a non-finite word (0x05), names a bad body (bad: the
// body RAM's flag of its body A or B, no new code), joins two static bodies (0x07), shares a dynamic body with an
// earlier issuing lane of the record (0x04; with BODY_BANKS and lanes also when the issuing lanes would read a
// body-velocity bank more than twice), was cut short by TLAST (rec_trunc), or its slot was rejected in an earlier pass
// of the step: a slot once rejected stays rejected for the rest of the step. The rejected-slot flags (one bit per slot,
// written for every slot in pass 0 and when a later pass rejects it): the streaming kernel reads them at the slot
// offered (a registered index: block RAM on a board); the window kernel per lane by record index, with the impulses in
// the records as each record is written into the ring (w_asm_move / w_asm_slot, its bit w_rej_q riding in the record's
// head back as w_head_seen: block RAM), else at the offered pass's slot (an asynchronous read, LUT RAM).
// `fill` (the streaming kernel's missing slots after an early TLAST) is a rejected slot stepped without a record.
// Errors: err_* pulse with the take of a checked lane (not empty, not cut short).
`default_nettype none

module pgs_seq_issue #(
    parameter int MAX_BODIES    = 65536,
    parameter int MAX_MANIFOLDS = 262144,
    parameter int WINDOW        = 0,
    parameter int LANES         = 1,
    parameter bit IMPULSES_IN_RECORDS = 1'b0,
    parameter int BODY_BANKS    = 0,
    localparam int IDX_W        = $clog2(MAX_BODIES),
    localparam int ITER_W       = pgs_seq_pkg::ITER_W
) (
    input  wire logic                   clk,
    input  wire logic                   in_solve,
    input  wire logic                   rec_valid,
    input  wire logic                   rec_trunc,
    input  wire logic                   fill,
    input  wire logic                   imp_room,
    input  wire logic                   may_issue,
    input  wire logic [ITER_W:0]        pass,
    input  wire logic [31:0]            slot,
    input  wire logic [LANES*IDX_W-1:0] la,
    input  wire logic [LANES*IDX_W-1:0] lb,
    input  wire logic [LANES-1:0]       l_empty_hdr,
    input  wire logic [LANES-1:0]       l_index,
    input  wire logic [LANES-1:0]       l_nonfinite,
    input  wire logic [2*LANES-1:0]     dyn,           // the body RAM's flags of each lane's body A (2l), B (2l + 1)
    input  wire logic [2*LANES-1:0]     bad,
    input  wire logic                   w_asm_move,
    input  wire logic [31:0]            w_asm_slot,
    output logic      [LANES-1:0]       w_rej_q,
    input  wire logic [LANES-1:0]       w_head_seen,
    output logic                        take,
    output logic      [LANES-1:0]       l_go,          // the lanes that issue if the record is taken
    output logic      [LANES-1:0]       l_issue,
    output logic      [LANES-1:0]       l_reject,
    output logic                        issue,
    output logic                        fill_step,
    output logic                        slot_step,     // the slot offered is done (taken, or a fill slot stepped)
    output logic                        err_body_index,
    output logic                        err_nonfinite,
    output logic                        err_static_pair
);
    localparam int SLOT_W  = $clog2(MAX_MANIFOLDS);
    localparam int BSLOT_W = $clog2(MAX_MANIFOLDS / LANES);   // a record index (slot of lane 0 / LANES)
    // with banked body velocities and lanes, a lane that would have the issuing lanes read some bank more than twice
    // (its ports) is rejected like a lane sharing a dynamic body (the host's lane plan keeps apart the manifolds that
    // would: models/kernel/record_window.py): a record's reads then fit the banks' ports, and so do its retire's writes
    localparam int BANK_W = BODY_BANKS > 1 ? $clog2(BODY_BANKS) : 1;
    /* verilator lint_off UNUSEDSIGNAL */  // b: a body's bank is its index's low bits
    function automatic logic [BANK_W-1:0] bank_of(input logic [IDX_W-1:0] b);
        return BODY_BANKS > 1 ? b[BANK_W-1:0] : '0;
    endfunction
    /* verilator lint_on UNUSEDSIGNAL */

    logic [LANES-1:0] l_rej_seen;   // slots rejected earlier in the step (written for every slot in pass 0)
    logic [LANES-1:0] l_empty, l_static, l_collide, l_rej;
    always_comb begin
        automatic logic [LANES-1:0] go = '0;   // the lanes so far that issue
        for (int l = 0; l < LANES; l++) begin
            automatic logic rej_prev = pass != '0 && l_rej_seen[l];
            automatic logic rej_bad;
            automatic logic [IDX_W-1:0] a = la[l*IDX_W +: IDX_W];
            automatic logic [IDX_W-1:0] b = lb[l*IDX_W +: IDX_W];
            l_empty[l]  = WINDOW > 0 && !rec_trunc && l_empty_hdr[l];
            rej_bad     = !l_index[l] && (bad[2*l] || bad[2*l+1]);
            l_static[l] = !l_index[l] && !rej_bad && !dyn[2*l] && !dyn[2*l+1];
            l_collide[l] = 1'b0;
            for (int k = 0; k < l; k++) begin
                automatic logic [IDX_W-1:0] ak = la[k*IDX_W +: IDX_W];
                automatic logic [IDX_W-1:0] bk = lb[k*IDX_W +: IDX_W];
                if (go[k] && ((dyn[2*l] && (a == ak || a == bk)) || (dyn[2*l+1] && (b == ak || b == bk))))
                    l_collide[l] = 1'b1;
            end
            if (BODY_BANKS > 0 && LANES > 1) begin   // the reads of bodies A and B in their banks, earlier lanes'
                automatic int in_a = bank_of(a) == bank_of(b) ? 2 : 1;
                automatic int in_b = in_a;
                for (int k = 0; k < l; k++) begin   // the earlier issuing lanes' reads
                    if (go[k]) begin
                        in_a += int'(bank_of(la[k*IDX_W +: IDX_W]) == bank_of(a))
                                + int'(bank_of(lb[k*IDX_W +: IDX_W]) == bank_of(a));
                        in_b += int'(bank_of(la[k*IDX_W +: IDX_W]) == bank_of(b))
                                + int'(bank_of(lb[k*IDX_W +: IDX_W]) == bank_of(b));
                    end
                end
                if (in_a > 2 || in_b > 2) l_collide[l] = 1'b1;
            end
            l_rej[l] = rej_prev || l_index[l] || rej_bad || l_static[l] || l_nonfinite[l] || rec_trunc
                       || l_collide[l];
            go[l]    = !l_empty[l] && !l_rej[l];
        end
        l_go = go;
    end
    assign take      = in_solve && rec_valid && !fill && imp_room && (l_go == '0 || may_issue);
    assign l_issue   = {LANES{take}} & l_go;
    assign l_reject  = {LANES{take}} & ~l_empty & l_rej;
    assign issue     = l_issue != '0;
    assign fill_step = in_solve && fill && imp_room;
    assign slot_step = take || fill_step;

    // the rejected-slot flags (see the header)
    generate
        if (WINDOW == 0) begin : g_rej_stream
            logic slot_rej [MAX_MANIFOLDS];
            assign l_rej_seen[0] = slot_rej[slot[SLOT_W-1:0]];
            always_ff @(posedge clk) begin
                if (slot_step && (pass == '0 || l_reject[0] || fill_step))
                    slot_rej[slot[SLOT_W-1:0]] <= l_reject[0] || fill_step;
            end
            assign w_rej_q = '0;
            wire unused_rej = ^{w_asm_move, w_asm_slot, w_head_seen, slot[31:SLOT_W]};
        end else if (IMPULSES_IN_RECORDS) begin : g_rej_ring
            for (genvar l = 0; l < LANES; l++) begin : g_lane_rej
                pgs_ring_ram #(.WIDTH(1), .DEPTH(MAX_MANIFOLDS / LANES), .SYNC_READ(1'b1)) u_slot_rej (
                    .clk, .wr_en(slot_step && (pass == '0 || l_reject[l])), .wr_addr(slot[BSLOT_W-1:0]),
                    .wr_data(l_reject[l]), .rd_en(w_asm_move), .rd_addr(w_asm_slot[BSLOT_W-1:0]),
                    .rd_data(w_rej_q[l]));
            end
            assign l_rej_seen = w_head_seen;
            wire unused_rej = ^{w_asm_slot[31:BSLOT_W], slot[31:BSLOT_W]};
        end else begin : g_rej_window
            for (genvar l = 0; l < LANES; l++) begin : g_lane_rej
                pgs_ring_ram #(.WIDTH(1), .DEPTH(MAX_MANIFOLDS / LANES), .SYNC_READ(1'b0)) u_slot_rej (
                    .clk, .wr_en(slot_step && (pass == '0 || l_reject[l])), .wr_addr(slot[BSLOT_W-1:0]),
                    .wr_data(l_reject[l]), .rd_en(1'b0), .rd_addr(slot[BSLOT_W-1:0]), .rd_data(l_rej_seen[l]));
            end
            assign w_rej_q = '0;
            wire unused_rej = ^{w_asm_move, w_asm_slot, w_head_seen, slot[31:BSLOT_W]};
        end
    endgenerate

    // errors: the checks of each lane taken, not empty and not cut short by TLAST (its words are stale then)
    wire [LANES-1:0] checked = {LANES{take && !rec_trunc}} & ~l_empty;
    assign err_body_index  = (checked & (l_index | l_collide)) != '0;
    assign err_nonfinite   = (checked & l_nonfinite) != '0;
    assign err_static_pair = (checked & l_static) != '0;
endmodule

`default_nettype wire
