// pgs_window: the record window of a kernel built with WINDOW > 0: each manifold's combined
// record (contact and friction words) is read from the constraint stream once per *fetch* and serves the
// `fetch_passes` passes of that fetch from an on-chip ring of DEPTH records, the passes trailing each other.
//
// Stream: ceil(passes / fetch_passes) fetches of nm combined records each (models/kernel/stream_format.py
// pack_window_stream: 64-bit header, 23 contact words, 14 friction words, padded to REC_BEATS beats),
// TLAST on the last beat of each fetch. Fetch f serves passes f*fetch_passes .. (f+1)*fetch_passes - 1 of
// models.golden.contact_solver.pass_sequence. Record k of a fetch is manifold slot k.
//
// Passes: pass j steps its slots in order 0 .. nm-1, one slot per `take`. Up to CTX passes are active at a
// time (pass contexts, pass j in context j mod CTX). The last pass of a fetch starts only once every pass of the
// earlier fetches is done: the last passes of two fetches never interleave their takes, so records leave the ring
// in the order they were written (the room rule below counts on it) and, with the impulses in the records, the
// last passes' impulse-out records leave fetch by fetch. A slot s of pass j is a candidate when its record is in
// the ring and pass j-1 is done or has stepped at least s + lag slots. With lag >= the schedule's band width D
// (every dynamic body's manifolds lie within D consecutive slots) pass j-1 has issued every update of the bodies
// of slot s before pass j reads them, and pass j's updates of a body all come before pass j+1's: every body sees
// its updates in the order of the sequential solve, so the result is bit for bit the golden model's
// (the sequencer's hazard CAM keeps an update that is still in flight from being read early).
// Each cycle one candidate is offered: the oldest pass with a candidate, skipping contexts whose candidate was
// offered and not taken since the last take (a hazard stall), so that another pass can fill the cycle.
//
// Ring: a fetched record is written in arrival order (global record index = fetch * nm + slot); it is freed
// when the last pass of its fetch steps its slot, in the order of the global index (the pass rule above). Beats
// are accepted only while the ring has room. The
// host's argument check (sequencer) guarantees progress: 1 <= fetch_passes <= CTX, lag >= 1 and
// (fetch_passes - 1) * lag + 2 <= DEPTH.
// The ring is two arrays with one write port each (the record written, at ring address = global index mod
// DEPTH): the *heads* (HEAD_W bits per record, `wr_head`, which the sequencer derives from the record `wr_rec`
// being written: body indices, flags, the checks that depend only on the record) are read in the cycle before a
// candidate is offered, at the address the next cycle's choice gives (`cand_head`: a registered read, block RAM
// on a board; the choice is made a cycle ahead, below), the whole records are read one cycle after the take
// (`rd_rec`, a registered read of the taken candidate's address: block RAM), when the sequencer's stage 1 needs
// the words. `cand_addr` is the candidate's ring address, `cand_first` / `cand_lastg` whether its pass is
// the first / the last of its fetch.
//
// Stream errors (code 1, tlast_err): a fetch whose TLAST comes early -- the record cut short is kept with its
// trunc bit, the slots the fetch lacks enter the ring as truncated records (one per cycle), and the sequencer
// rejects them in every pass; one whose TLAST is late -- the beats after its last record are discarded up to
// TLAST (`flushing`).
`default_nettype none

module pgs_window #(
    parameter int CONS_W    = 512,
    parameter int REC_BEATS = 3,
    parameter int DEPTH     = 16384,   // records in the ring, a power of two
    parameter int CTX       = 8,       // pass contexts, a power of two
    parameter int PASS_W    = 17,
    parameter int HEAD_W    = 64,      // bits of a record read in the cycle it is offered (wr_head, cand_head)
    localparam int REC_W    = REC_BEATS * CONS_W,
    localparam int AW       = $clog2(DEPTH),
    localparam int CW       = $clog2(CTX),
    localparam int GI_W     = 52       // global record index (fetch * nm + slot)
) (
    input  wire                clk,
    input  wire                rst,
    input  wire                init,          // start of a step: clear the state
    input  wire                first_start,   // a pass starts in the first cycle after init (the step has passes and
                                              // records: from the run's arguments, as the sequencer samples them)
    input  wire  [31:0]        nm,
    input  wire  [PASS_W-1:0]  passes,
    input  wire  [PASS_W-1:0]  fetch_passes,
    input  wire  [31:0]        lag,
    input  wire                fetch_en,      // the sequencer's LOAD and SOLVE phases
    input  wire  [CONS_W-1:0]  s_tdata,
    input  wire                s_tvalid,
    output logic               s_tready,
    input  wire                s_tlast,
    output logic               asm_move,      // a record enters the assembler's output: it is written next cycle
    output logic [31:0]        asm_slot,      // ... its slot
    output logic               asm_first,     // ... it belongs to the step's first fetch
    output logic [REC_W-1:0]   wr_rec,        // the record being written into the ring (zeros: a truncated slot)
    input  wire  [HEAD_W-1:0]  wr_head,       // its head (combinational from wr_rec)
    output logic               cand_valid,
    output logic [HEAD_W-1:0]  cand_head,
    output logic [AW-1:0]      cand_addr,
    output logic               cand_first,    // the candidate's pass is the first pass of its fetch
    output logic               cand_lastg,    // ... the last pass of its fetch
    output logic               cand_trunc,
    output logic [REC_W-1:0]   rd_rec,        // the record taken in the previous cycle
    output logic [PASS_W-1:0]  cand_pass,
    output logic [PASS_W:0]    start_pass_no,  // the pass started next ...
    input  wire                start_kind,     // ... its kind (a pass's kind is kept with its context)
    output logic               cand_kind,      // the candidate's pass's kind
    output logic [31:0]        cand_slot,
    input  wire                take,          // the candidate is consumed (issued or rejected)
    output logic               all_done,      // every pass has stepped every slot
    output logic               flushing,
    output logic               tlast_err
);
    localparam int NEED_W = $clog2(REC_BEATS + 1);

    // ---------------- fetch into the ring ----------------
    logic [HEAD_W:0] cand_head_trunc;   // {truncated, head} of the candidate
    logic [GI_W-1:0]  wr_cnt;                      // records written
    logic [AW:0]      used;                        // records reserved (assembling or written) and not yet freed
    logic [PASS_W:0]  f_base;                      // first pass of the fetch being assembled
    logic [31:0]      f_slot;
    logic             fill;                        // writing the truncated slots after an early TLAST
    logic             a_pending;                   // a record is done in the assembler, not yet written

    wire f_active = f_base < (PASS_W+1)'(passes) && nm != 0;
    wire room     = !used[AW];   // used < DEPTH (it never passes DEPTH: a record is reserved only with room)
    wire f_last   = f_slot == nm - 1;

    logic [REC_W-1:0] arec;
    logic             a_ready;
    logic             arec_valid, arec_trunc, a_done, a_done_trunc, a_unused_tag, a_unused_last;
    pgs_record_asm #(.BEAT_W(CONS_W), .MAX_BEATS(REC_BEATS), .TAG_W(1)) u_asm (
        .clk, .rst, .enable(fetch_en && f_active && !flushing && !fill && room), .need(NEED_W'(REC_BEATS)),
        .in_tag(1'b0), .s_tdata, .s_tvalid, .s_tlast, .s_tready(a_ready), .done(a_done), .done_trunc(a_done_trunc),
        .rec_data(arec), .rec_tag(a_unused_tag), .rec_last(a_unused_last), .rec_trunc(arec_trunc),
        .rec_valid(arec_valid), .rec_ready(1'b1));
    assign s_tready = a_ready || flushing;

    wire fill_step = fill && !a_pending && room;    // the record that carried TLAST goes in first
    wire wr_step   = arec_valid || fill_step;
    assign tlast_err = a_done && (s_tlast != f_last || a_done_trunc);
    // the record whose last beat was taken in the previous cycle enters the assembler's output register now
    // (pgs_record_asm: its output is always taken) and is written into the ring in the next cycle
    always_ff @(posedge clk) begin
        if (rst || init) asm_move <= 1'b0;
        else             asm_move <= a_done;
        if (a_done) begin
            asm_slot  <= f_slot;
            asm_first <= f_base == '0;
        end
    end

    assign wr_rec = arec_valid ? arec : '0;
    // the records (read one cycle after the take) and their heads with the truncated bit (read when offered)
    pgs_ring_ram #(.WIDTH(REC_W), .DEPTH(DEPTH), .SYNC_READ(1'b1)) u_records (
        .clk, .wr_en(wr_step), .wr_addr(wr_cnt[AW-1:0]), .wr_data(wr_rec), .rd_en(take), .rd_addr(cand_addr),
        .rd_data(rd_rec));
    // the heads: block RAM read at the next cycle's candidate address (`next_addr`, below), so that the head of the
    // candidate is there when it is offered; a head written in the cycle of its read comes from the bypass register
    logic [HEAD_W:0] head_ram, wr_head_trunc, head_byp;
    logic            byp;
    logic [AW-1:0]   next_addr;
    logic [1:0]      next_written;   // the next address is the one written now, the candidate taken (1) or not (0)
    assign wr_head_trunc = {arec_valid ? arec_trunc : 1'b1, wr_head};
    pgs_ring_ram #(.WIDTH(HEAD_W + 1), .DEPTH(DEPTH), .SYNC_READ(1'b1)) u_heads (
        .clk, .wr_en(wr_step), .wr_addr(wr_cnt[AW-1:0]), .wr_data(wr_head_trunc), .rd_en(1'b1),
        .rd_addr(next_addr), .rd_data(head_ram));
    always_ff @(posedge clk) begin
        byp      <= wr_step && (take ? next_written[1] : next_written[0]);
        head_byp <= wr_head_trunc;
    end
    assign cand_head_trunc = byp ? head_byp : head_ram;

    // ---------------- pass contexts ----------------
    logic [PASS_W-1:0] c_pass  [CTX];
    logic [31:0]       c_slot  [CTX];
    logic [GI_W-1:0]   c_gidx  [CTX];
    logic [CTX-1:0]    c_active, c_lastg, c_first, c_kind, skip;
    logic [CTX-1:0]    c_last;            // the context's slot is its pass's last (c_slot == nm - 1)
    logic [PASS_W:0]   st_pass, jlo;      // next pass to start; oldest pass not done
    logic [PASS_W-1:0] st_k;              // st_pass's place in its fetch
    logic [GI_W-1:0]   st_base;           // global index of slot 0 of st_pass's fetch

    wire [CW-1:0] jlo_ctx = jlo[CW-1:0];
    // a pass starts (st_pass, one a cycle) while one is left, fewer than CTX are not done, and a fetch's last pass
    // only once every pass of the earlier fetches is done. `start_pass` is a register: the rule is evaluated a cycle
    // ahead, on the next cycle's st_pass, st_k and jlo (none depends on the take), and after init from the run's
    // arguments (first_start: st_pass = jlo = st_k = 0).
    logic           start_pass;
    wire            st_lastg = st_k == fetch_passes - 1'b1 || st_pass == (PASS_W+1)'(passes) - 1'b1;
    wire [PASS_W:0] st_pass_next = st_pass + (PASS_W+1)'(start_pass);
    wire [PASS_W-1:0] st_k_next  = !start_pass ? st_k : st_lastg ? '0 : st_k + 1'b1;
    wire            st_lastg_next = st_k_next == fetch_passes - 1'b1 || st_pass_next == (PASS_W+1)'(passes) - 1'b1;

    // A context's slot is a candidate (eligible) when its record is in the ring and the pass before it is done or
    // far enough ahead. Of the eligible contexts the oldest not skipped is offered, else the oldest eligible one (the
    // contexts rotated to start at the oldest pass's, the first set bit found, rotated back).
    //
    // The choice is made a cycle ahead, so that no path runs from the take to the next cycle's choice and its head:
    // each cycle computes the next cycle's state both ways this cycle can end (the candidate taken or not), chooses
    // for each, and the take picks one choice into registers (`sel`, `any_elig`, `any_fresh`) and one address for
    // the heads' block RAM read. These are the values a choice from the next cycle's registers would give: no cycle
    // changes. The eligibility's two wide comparisons (the record in the ring, the pass before lag slots ahead) are
    // each computed from the registers once per way the take and a pass start can change them.
    function automatic logic [CTX-1:0] rotate_down(input logic [CTX-1:0] v, input logic [CW-1:0] by);
        return CTX'({v, v} >> by);
    endfunction
    function automatic logic [CW-1:0] first_set(input logic [CTX-1:0] v);
        logic [CW-1:0] i = '0;
        for (int off = CTX - 1; off >= 0; off--)
            if (v[off]) i = CW'(off);
        return i;
    endfunction
    typedef struct packed {
        logic          any_elig;    // a candidate
        logic          any_fresh;   // ... one not skipped
        logic [CW-1:0] sel;         // its context
    } choice_t;
    function automatic choice_t choose(input logic [CTX-1:0] elig, input logic [CTX-1:0] skp,
                                       input logic [CW-1:0] oldest);
        automatic logic [CTX-1:0] r_elig  = rotate_down(elig, oldest);
        automatic logic [CTX-1:0] r_fresh = rotate_down(elig & ~skp, oldest);
        choice_t c;
        c.any_elig  = r_elig != '0;
        c.any_fresh = r_fresh != '0;
        c.sel       = oldest + (c.any_fresh ? first_set(r_fresh) : first_set(r_elig));
        return c;
    endfunction

    logic [CW-1:0]  sel;              // registered: this cycle's choice
    logic           any_fresh, any_elig;
    assign cand_valid = any_elig;
    assign cand_addr  = c_gidx[sel][AW-1:0];
    assign cand_head  = cand_head_trunc[HEAD_W-1:0];
    assign cand_trunc = cand_head_trunc[HEAD_W];
    assign cand_first = c_first[sel];
    assign cand_kind  = c_kind[sel];
    assign start_pass_no = st_pass;
    assign cand_lastg = c_lastg[sel];
    assign cand_pass  = c_pass[sel];
    assign cand_slot  = c_slot[sel];
    assign all_done   = jlo == (PASS_W+1)'(passes);
    wire   step_last  = c_last[sel];

    // The eligibility's two comparisons (the pass before lag slots ahead, the record in the ring) are on differences
    // that move by at most one a cycle: the pass before's slot minus k's minus the lag (`d`), k's slot minus the lag
    // (`e`, for the context started after k), the records written minus k's record (`g`), and minus st_base (`sr`).
    // Each cycle computes them for the next cycle (the candidate not taken: a start resets a context's slot and
    // record, a write moves wr_cnt on) and registers the few comparisons with small constants the next cycle's
    // choice needs, shifted by one where the take moves them (the take picks). So the choice reads flags, not a wide
    // subtraction. Exact from the second cycle of a step: the first's choice reads only a started context's `sr`
    // (reset with wr_cnt and st_base) and the `e` of a context not active (the lag is sampled as the step starts).
    wire [CW-1:0] st_ctx = st_pass[CW-1:0];
    localparam int DW = 34;
    localparam int GW = GI_W + 1;
    // x >= t for t = -3 .. 3 at bit t + 3 (a sign and the bits above the lowest two all zero or all one)
    function automatic logic [6:0] at_least(input logic signed [GW-1:0] x);
        automatic logic neg = x[GW-1];
        automatic logic hi0 = x[GW-1:2] == '0, hi1 = &x[GW-1:2];
        automatic logic [1:0] lo = x[1:0];
        return {!neg && (!hi0 || lo == 2'd3), !neg && (!hi0 || lo[1]), !neg && (!hi0 || lo != 2'd0), !neg,
                !neg || (hi1 && lo == 2'd3), !neg || (hi1 && lo[1]), !neg || (hi1 && lo != 2'd0)};
    endfunction
    logic [1:0] e_at [CTX];   // {e >= 0, e >= -1}
    logic [2:0] d_at [CTX];   // {d >= 1, d >= 0, d >= -1}
    logic [2:0] g_at [CTX];   // {g >= 2, g >= 1, g >= 0}
    logic [1:0] g_lo [CTX];   // {g = 1, g = 0} modulo DEPTH: c_gidx + 1, c_gidx at the ring address being written
    logic [1:0] sr_at;        // {sr >= 1, sr >= 0}
    logic       sr_lo;        // st_base at the ring address being written
    logic [6:0] e_at_n [CTX], d_at_n [CTX], g_at_n [CTX];   // the next cycle's, the candidate not taken
    logic [2:0] g_lo_n [CTX];                                // {g = 2, 1, 0} modulo DEPTH, likewise
    logic [6:0] sr_at_n;
    logic       sr_lo_n;
    always_comb begin
        automatic logic [GI_W-1:0] wr_cnt_n  = wr_cnt + GI_W'(wr_step);
        automatic logic [GI_W-1:0] st_base_n = start_pass && st_lastg ? st_base + GI_W'(nm) : st_base;
        automatic logic signed [GW-1:0] sr  = $signed({1'b0, wr_cnt_n}) - $signed({1'b0, st_base_n});
        for (int k = 0; k < CTX; k++) begin
            automatic logic [CW-1:0] p = CW'(k - 1);
            automatic logic [31:0] slot_k = start_pass && st_ctx == CW'(k) ? '0 : c_slot[k];
            automatic logic [31:0] slot_p = start_pass && st_ctx == p ? '0 : c_slot[p];
            automatic logic [GI_W-1:0] gidx_k = start_pass && st_ctx == CW'(k) ? st_base : c_gidx[k];
            automatic logic signed [DW-1:0] e = $signed(DW'(slot_k)) - $signed(DW'(lag));
            automatic logic signed [DW-1:0] d = $signed(DW'(slot_p)) - $signed(DW'(slot_k)) - $signed(DW'(lag));
            automatic logic signed [GW-1:0] g = $signed({1'b0, wr_cnt_n}) - $signed({1'b0, gidx_k});
            e_at_n[k] = at_least(GW'(e));
            d_at_n[k] = at_least(GW'(d));
            g_at_n[k] = at_least(g);
            g_lo_n[k] = {g[AW-1:0] == AW'(2), g[AW-1:0] == AW'(1), g[AW-1:0] == '0};
        end
        sr_at_n = at_least(sr);
        sr_lo_n = sr[AW-1:0] == '0;
    end
    always_ff @(posedge clk) begin
        for (int k = 0; k < CTX; k++) begin
            automatic logic take_k = take && sel == CW'(k);         // k's slot and record one on: e + 1, d - 1, g - 1
            automatic logic take_p = take && sel == CW'(k - 1);     // the slot before's one on: d + 1
            e_at[k] <= take_k ? e_at_n[k][2:1] : e_at_n[k][3:2];
            d_at[k] <= take_p ? d_at_n[k][3:1] : take_k ? d_at_n[k][5:3] : d_at_n[k][4:2];
            g_at[k] <= take_k ? g_at_n[k][6:4] : g_at_n[k][5:3];
            g_lo[k] <= take_k ? g_lo_n[k][2:1] : g_lo_n[k][1:0];
        end
        if (rst || init) begin   // wr_cnt = st_base = 0
            sr_at <= 2'b01;
            sr_lo <= 1'b1;
        end else begin
            sr_at <= sr_at_n[4:3];
            sr_lo <= sr_lo_n;
        end
    end

    // the oldest pass is done: jlo moves on (jlo_open: a pass started and not done, jlo != st_pass, a register
    // evaluated a cycle ahead like start_pass; the choice reads only the context bits of jlo's next)
    logic            jlo_open;
    wire             jlo_step = jlo_open && !c_active[jlo_ctx];
    wire [PASS_W:0]  jlo_next = jlo + (PASS_W+1)'(jlo_step);
    wire [CW-1:0]    jlo_ctx_next = jlo_ctx + CW'(jlo_step);
    wire start_pass_next = st_pass_next < (PASS_W+1)'(passes) && st_pass_next - jlo_next < (PASS_W+1)'(CTX) && nm != 0
                           && (!st_lastg_next || jlo_next >= st_pass_next - (PASS_W+1)'(st_k_next));
    // the next cycle's state, taken (index 1) or not (0): a context k started now (slot 0, record st_base), taken
    // now (its slot and record one on) or neither; the context p before it likewise; a record written now (wr_cnt
    // one on)
    logic [CTX-1:0]  ahead_next [2], in_ring_next [2], active_next [2], skip_next [2], elig_next [2];
    choice_t         choice_next [2];
    logic [AW-1:0]   addr_next [2];
    always_comb begin
        for (int o = 0; o < 2; o++) begin
            for (int k = 0; k < CTX; k++) begin
                automatic logic [CW-1:0] p = CW'(k - 1);
                automatic logic take_k = o == 1 && sel == CW'(k);
                automatic logic take_p = o == 1 && sel == p;
                // c_slot[p] + take_p >= c_slot[k] + take_k + lag, c_gidx[k] + take_k < wr_cnt + wr_step
                if (start_pass && st_ctx == CW'(k)) begin
                    ahead_next[o][k]   = take_p ? e_at[p][0] : e_at[p][1];
                    in_ring_next[o][k] = wr_step ? sr_at[0] : sr_at[1];
                end else begin
                    if (start_pass && st_ctx == p) ahead_next[o][k] = 1'b0;   // slot 0 is never lag >= 1 ahead
                    else if (take_p)               ahead_next[o][k] = d_at[k][0];
                    else if (take_k)               ahead_next[o][k] = d_at[k][2];
                    else                           ahead_next[o][k] = d_at[k][1];
                    if (take_k) in_ring_next[o][k] = wr_step ? g_at[k][1] : g_at[k][2];
                    else        in_ring_next[o][k] = wr_step ? g_at[k][0] : g_at[k][1];
                end
                // (a start and a finish never hit the same context: st_pass - jlo < CTX)
                active_next[o][k] = (start_pass && st_ctx == CW'(k)) || (c_active[k] && !(take_k && step_last));
            end
            // a take clears the skip marks; an offer not taken marks its pass (or clears them: every one skipped)
            skip_next[o] = o == 1 ? '0 : !any_elig ? skip : any_fresh ? skip | (CTX'(1) << sel) : '0;
            for (int k = 0; k < CTX; k++) begin
                automatic logic [CW-1:0] p = CW'(k - 1);
                // (an active context holds a pass from jlo on, pass j in context j mod CTX: it holds jlo when it is
                // jlo's context)
                elig_next[o][k] = active_next[o][k] && in_ring_next[o][k]
                                  && (CW'(k) == jlo_ctx_next || !active_next[o][p] || ahead_next[o][k]);
            end
            choice_next[o] = choose(elig_next[o], skip_next[o], jlo_ctx_next);
            if (start_pass && st_ctx == choice_next[o].sel) begin
                addr_next[o]    = st_base[AW-1:0];
                next_written[o] = sr_lo;
            end else if (o == 1 && sel == choice_next[o].sel) begin
                addr_next[o]    = c_gidx[sel][AW-1:0] + 1'b1;
                next_written[o] = g_lo[sel][1];
            end else begin
                addr_next[o]    = c_gidx[choice_next[o].sel][AW-1:0];
                next_written[o] = g_lo[choice_next[o].sel][0];
            end
        end
    end
    assign next_addr = take ? addr_next[1] : addr_next[0];
    always_ff @(posedge clk) begin
        if (rst || init) {any_elig, any_fresh, sel} <= '0;   // no context active
        else             {any_elig, any_fresh, sel} <= take ? choice_next[1] : choice_next[0];
        if (rst)       start_pass <= 1'b0;
        else if (init) start_pass <= first_start;
        else           start_pass <= start_pass_next;
        if (rst || init) jlo_open <= 1'b0;   // jlo = st_pass = 0
        else             jlo_open <= jlo_next != st_pass_next;
    end

    always_ff @(posedge clk) begin
        if (rst || init) begin
            wr_cnt   <= '0;
            used     <= '0;
            f_base   <= '0;
            f_slot   <= '0;
            fill     <= 1'b0;
            a_pending <= 1'b0;
            flushing <= 1'b0;
            c_active <= '0;
            skip     <= '0;
            st_pass  <= '0;
            jlo      <= '0;
            st_k     <= '0;
            st_base  <= '0;
        end else begin
            // fetch
            if (wr_step) wr_cnt <= wr_cnt + 1'b1;
            if (a_done) a_pending <= 1'b1;
            else if (arec_valid) a_pending <= 1'b0;
            // a record reserved (its last beat taken, or a truncated slot), one freed (the take of its fetch's last
            // pass)
            used <= used + (AW+1)'(a_done || fill_step) - (AW+1)'(take && c_lastg[sel]);
            if (a_done || fill_step) begin
                if (f_last) begin
                    f_slot <= '0;
                    f_base <= f_base + (PASS_W+1)'(fetch_passes);
                    fill   <= 1'b0;
                    if (a_done && !s_tlast) flushing <= 1'b1;   // TLAST late: discard up to it
                end else begin
                    f_slot <= f_slot + 1;
                    if (a_done && s_tlast) fill <= 1'b1;       // TLAST early: the fetch's other slots are truncated
                end
            end
            if (flushing && s_tvalid && s_tlast) flushing <= 1'b0;
            // start a pass
            if (start_pass) begin
                c_pass[st_pass[CW-1:0]]   <= st_pass[PASS_W-1:0];
                c_slot[st_pass[CW-1:0]]   <= '0;
                c_last[st_pass[CW-1:0]]   <= nm == 32'd1;
                c_gidx[st_pass[CW-1:0]]   <= st_base;
                c_lastg[st_pass[CW-1:0]]  <= st_lastg;
                c_first[st_pass[CW-1:0]]  <= st_k == '0;
                c_kind[st_pass[CW-1:0]]   <= start_kind;
                if (st_lastg) st_base <= st_base + GI_W'(nm);
            end
            // step the candidate's pass
            if (take) begin
                c_slot[sel] <= c_slot[sel] + 1;
                c_last[sel] <= c_slot[sel] + 32'd2 == nm;
                c_gidx[sel] <= c_gidx[sel] + 1'b1;
            end
            st_pass <= st_pass_next;
            st_k    <= st_k_next;
            // the skip marks, the contexts' activity and the oldest pass (as the choice above computed them)
            skip     <= take ? skip_next[1] : skip_next[0];
            c_active <= take ? active_next[1] : active_next[0];
            jlo      <= jlo_next;
        end
    end

    // Not needed: the assembler's tag and TLAST of a record (the fetch counters track the slots); the comparisons of
    // `sr` the take does not move.
    wire unused_win = ^{a_unused_tag, a_unused_last, sr_at_n[6:5], sr_at_n[2:0]};
endmodule

`default_nettype wire
