// pgs_sequencer: one step of the kernel (everything below the register file).
//
// Phases after `start` (arguments sampled then):
//   LOAD   num_bodies body-in records from s_body into the body RAM (the constraint stream is already
//          being assembled meanwhile);
//   SOLVE  the passes of models.golden.contact_solver.pass_sequence (contact passes then friction passes, or
//          interleaved when opt_interleaved): num_manifolds records per pass, record k of a pass =
//          manifold slot k. A record issues (one per cycle at most, II = 1) when it is assembled and
//          no manifold in flight shares a dynamic body with it (pgs_hazard_cam), and -- with two pipes
//          per lane (SHARED_DATAPATH = 0), when the pass kind changes -- when the other pipe has drained
//          (retire stays in order, one write per body port per cycle). Issue cycle t: read bodies A, B
//          and the slot's impulses (registered RAMs); t+1: the lane's datapath (pgs_lane_datapath: one
//          shared datapath for both kinds, or the kind's pipe) takes the record; at retire
//          (t+1+LATENCY) the impulses are written to the slot and the velocities of the dynamic bodies to
//          the body RAM; the trace record leaves then.
//          With WINDOW > 0 (the window kernel) the records come from pgs_window instead: each
//          manifold's combined record is streamed once per fetch of arg_fetch_passes passes and the passes
//          trail each other by arg_lag slots over the on-chip ring (see pgs_window); records of several
//          passes interleave at issue, and the friction pipe's output is delayed to the contact pipe's
//          latency so that retire stays in issue order without draining at a kind change. With
//          IMPULSES_IN_RECORDS each fetch serves passes of one kind and streams that kind's records with the
//          impulses the fetch starts from; an impulse ring (per lane, at the record's ring address) carries the
//          updated impulses from pass to pass within the fetch, and the fetch's last pass writes them to m_imp
//          (rtl/README.md "Impulses in the records" under the window kernel).
//          With LANES > 1 (window kernel only) each window record holds LANES manifolds' combined records
//          (slots k * LANES .. k * LANES + LANES - 1, the host's lane plan: body-disjoint, an all-ones
//          header pads an empty lane); they issue together into LANES copies of the pipes, with 2 x LANES
//          body RAM ports, one impulse RAM bank per lane (lane l holds slots = l mod LANES) and one CAM
//          entry per issue; num_manifolds counts the slots (a multiple of LANES, else error 3).
//   DRAIN  until the last manifold has retired;
//   INTEG  every body in index order through pgs_integrate_pipe (a static body's record rides in the
//          tag and comes out unchanged), into an output FIFO (issue only with a free FIFO credit, so
//          the no-backpressure pipe never overflows), serialized to m_body beats, TLAST on the last
//          beat of the last body;
//   DONE   one cycle: done (= ap_done and ap_ready).
// Counters (pgs_run_counters; cleared at start, frozen after done): cycles (start .. done inclusive), stall cycles
// (SOLVE, a record is assembled but may not issue: hazard, CAM full, two pipes' switch drain or a busy body bank), bubble
// cycles (SOLVE, no record assembled), issued manifold-passes, rejected manifold-passes (issued +
// rejected + empty lanes = num_manifolds * 2 * iterations), and the floating-point events of the three datapaths
// (overflow, underflow, invalid: every operator result of an issued manifold-pass or of a dynamic body's
// integration; saturating at 2^32 - 1; fp_set pulses with the events of a cycle).
//
// Bad input (rtl/README.md "Bad input"; pgs_error_flags: err_set pulses a flag, err_code its code):
//   * body-in records are checked at load: a non-finite word (0x05), a negative inverse mass or inverse
//     inertia (0x06), or a record cut short by TLAST (0x02) makes a *bad body*: stored frozen (not
//     dynamic), every manifold naming it is rejected, integration passes its record through unchanged.
//     An early TLAST (fewer bodies than num_bodies, 0x02) loads the missing bodies as zero records, bad;
//     a late one (more) discards the extra beats up to TLAST (0x02). The step goes on.
//   * constraint records are checked at issue. A record is *rejected* (consumed, never issued: no pipe,
//     no trace, no write) when it names a body >= num_bodies or the same body twice (0x04), holds a
//     non-finite word (0x05), joins two static bodies (0x07), shares a dynamic body with an earlier issuing
//     lane of its window record (0x04; LANES > 1), names a bad body (no new flag), was cut
//     short by TLAST (0x01), or its manifold slot was rejected in an earlier pass of the step: a slot
//     once rejected stays rejected for the rest of the step (a one-bit-per-slot memory written for every
//     slot in the first pass), so the bodies it names see the manifold as absent from then on, exactly.
//     TLAST before the last record of a pass (0x01) ends the pass there: its missing slots are rejected
//     (one per cycle); TLAST missing on the last record (0x01) discards the extra beats up to the next
//     TLAST. Every pass stays in step with the host's transfers, so the step always ends.
//   * 0x03 bad argument (num_bodies > MAX_BODIES, num_manifolds > MAX_MANIFOLDS or iterations >= 2^16; with
//     WINDOW > 0 also fetch_passes = 0, fetch_passes > WINDOW_CTX, lag = 0 or (fetch_passes - 1) * lag + 2 >
//     WINDOW, and with IMPULSES_IN_RECORDS a fetch that would serve contact and friction passes): the step ends at
//     once, streams untouched.
`default_nettype none

module pgs_sequencer #(
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
    parameter int WINDOW         = 0,      // 0: every pass streams its records; > 0: record window of WINDOW records
    parameter int WINDOW_CTX     = 8,      // passes active at a time in the window (a power of two >= 2)
    parameter int LANES          = 1,      // manifolds issued per cycle (a power of two; > 1 needs WINDOW > 0)
    parameter int IINV_W         = 3,      // inverse-inertia words per body: 1 scalar, 3 diagonal, 6 symmetric 3x3
    parameter bit IMPULSES_IN_RECORDS = 1'b0,  // 1: impulses travel with the records, out on m_imp (no impulse RAM)
    parameter int IMP_FIFO_DEPTH = 256,    // IMPULSES_IN_RECORDS: impulse-out records between take and handshake
    parameter int MU_W           = 0,      // friction-coefficient words per friction record: 0 the constant, 1 a word
    parameter int BODY_BANKS     = 0,      // > 0 (LANES = 1): body velocities in banks; a busy bank stalls the issue
    parameter bit TANGENTS_ON_CHIP = 1'b0, // 1: friction records without t0, t1; pgs_friction_pipe_tb derives them
    parameter bit SOFT_CONTACT   = 1'b0,   // 1 (IINV_W = 3): the soft contact pipe, lam * keep before the add
    parameter int DELAY_BLOCK_MIN_DEPTH = 0, // the pipes' delay lines at least this deep in block RAM (0: LUT RAM)
    parameter bit SHARED_DATAPATH = 1'b1,  // 1: one datapath per lane for both passes; 0: a contact and a friction pipe
    localparam int W             = 1 + EXP_BITS + MAN_BITS,
    localparam int TRACE_W       = 16 * W + 64,
    localparam int IMP_OUT_W     = (LANES * 4 * W + 7) / 8 * 8
) (
    input  wire                   clk,
    input  wire                   rst,
    input  wire                   start,
    output logic                  idle,
    output logic                  done,
    input  wire  [31:0]           arg_num_bodies,
    input  wire  [31:0]           arg_num_manifolds,
    input  wire  [31:0]           arg_iterations,
    input  wire  [W-1:0]          arg_dt,
    input  wire  [W-1:0]          arg_gx,
    input  wire  [W-1:0]          arg_gy,
    input  wire  [W-1:0]          arg_gz,
    input  wire  [W-1:0]          arg_damping,
    input  wire                   opt_interleaved,
    input  wire  [31:0]           arg_lag,           // WINDOW > 0: slots a pass trails the pass before it
    input  wire  [31:0]           arg_fetch_passes,  // WINDOW > 0: passes served by one fetch of the records
    input  wire                   opt_soft,          // SOFT_CONTACT: the keep factors apply (clear: keep = 1)
    input  wire  [W-1:0]          arg_keep_dyn,      // SOFT_CONTACT: keep factor of a row of two dynamic bodies
    input  wire  [W-1:0]          arg_keep_static,   // SOFT_CONTACT: keep factor of a row with a static body
    input  wire  [BODY_IN_W-1:0]  s_body_tdata,
    input  wire                   s_body_tvalid,
    output logic                  s_body_tready,
    input  wire                   s_body_tlast,
    input  wire  [CONS_W-1:0]     s_cons_tdata,
    input  wire                   s_cons_tvalid,
    output logic                  s_cons_tready,
    input  wire                   s_cons_tlast,
    output logic [BODY_OUT_W-1:0] m_body_tdata,
    output logic                  m_body_tvalid,
    input  wire                   m_body_tready,
    output logic                  m_body_tlast,
    output logic [IMP_OUT_W-1:0]  m_imp_tdata,       // IMPULSES_IN_RECORDS: one record per slot and pass
    output logic                  m_imp_tvalid,
    input  wire                   m_imp_tready,
    output logic                  m_imp_tlast,
    output logic [7:0]            err_set,
    output logic [7:0]            err_code,
    output logic [2:0]            fp_set,       // {invalid, underflow, overflow} events this cycle
    output logic [63:0]           stat_cycles,
    output logic [31:0]           stat_stalls,
    output logic [31:0]           stat_bubbles,
    output logic [31:0]           stat_issued,
    output logic [31:0]           stat_rejected,
    output logic [31:0]           stat_fp_overflow,
    output logic [31:0]           stat_fp_underflow,
    output logic [31:0]           stat_fp_invalid,
    output logic [LANES-1:0]      trace_valid,
    output logic [LANES*TRACE_W-1:0] trace_data
);
    localparam int IDX_W     = $clog2(MAX_BODIES);
    localparam int SLOT_W    = $clog2(MAX_MANIFOLDS);
    localparam int ITER_W    = 16;
    localparam int BREC_W    = (14 + IINV_W) * W;                       // body record
    localparam int OREC_W    = 13 * W;                                  // body-out record
    localparam int B_BEATS   = (BREC_W + BODY_IN_W - 1) / BODY_IN_W;
    localparam int O_BEATS   = (OREC_W + BODY_OUT_W - 1) / BODY_OUT_W;
    // words of a contact / friction record after the header (pgs_stream_layout_pkg, generated from
    // models/kernel/stream_format.py): the friction record's 14 words (8 without t0, t1 when TANGENTS_ON_CHIP), then with
    // MU_W = 1 the manifold's coefficient; with IMPULSES_IN_RECORDS the contact record ends with lam[0..3], the
    // friction record with lam[0..3] and lamT[0..1] (the impulses its pass starts from)
    localparam int C_WORDS   = pgs_stream_layout_pkg::CONTACT_WORDS
                               + (IMPULSES_IN_RECORDS ? pgs_stream_layout_pkg::CONTACT_IMPULSE_WORDS : 0);
    localparam int F_COEFF   = pgs_stream_layout_pkg::friction_words(MU_W, TANGENTS_ON_CHIP);  // words up to the impulses
    localparam int F_WORDS   = F_COEFF + (IMPULSES_IN_RECORDS ? pgs_stream_layout_pkg::FRICTION_IMPULSE_WORDS : 0);
    localparam int S1_WORDS  = C_WORDS > F_WORDS ? C_WORDS : F_WORDS;   // the record words stage 1 holds
    localparam int C_BEATS   = (64 + C_WORDS * W + CONS_W - 1) / CONS_W;   // contact record
    localparam int F_BEATS   = (64 + F_WORDS * W + CONS_W - 1) / CONS_W;   // friction record
    localparam int CM_BEATS  = C_BEATS > F_BEATS ? C_BEATS : F_BEATS;
    // one lane's window record: the contact and friction words together (on-chip impulses), or with the impulses in
    // the records the record of its fetch's one pass kind (each fetch serves passes of one kind), padded to CM_BEATS
    localparam int WR_BEATS  = IMPULSES_IN_RECORDS ? CM_BEATS : (64 + (23 + F_COEFF) * W + CONS_W - 1) / CONS_W;
    localparam int CREC_W    = CM_BEATS * CONS_W;
    localparam int CNEED_W   = $clog2(CM_BEATS + 1);
    localparam int BNEED_W   = $clog2(B_BEATS + 1);
    // the window kernel with the impulses in the records: each retire also carries its ring address and whether its
    // pass is the last of its fetch (the impulse ring's write, the impulse-out record)
    localparam int RA_W      = WINDOW > 1 ? $clog2(WINDOW) : 1;
    localparam int WTAG_W    = WINDOW > 0 && IMPULSES_IN_RECORDS ? RA_W + 1 : 0;
    localparam int STAG_W    = WTAG_W + SLOT_W + ITER_W + 2 * IDX_W + 2;  // solver pipes' tag
    localparam int ITAG_W    = 1 + OREC_W;                              // integrate pipe's tag
    localparam int OBEAT_W   = $clog2(O_BEATS + 1);
    localparam int EV_W      = 16;                                      // the datapaths' event counts
    localparam int LG_L      = $clog2(LANES);
    localparam int BSLOT_W   = $clog2(MAX_MANIFOLDS / LANES);              // a record index (slot of lane 0 / LANES)

    localparam bit CONTACT  = 1'b0;
    localparam bit FRICTION = 1'b1;

    if (LANES < 1 || (LANES & (LANES - 1)) != 0 || (LANES > 1 && WINDOW == 0)) begin : g_bad_lanes
        $error("pgs_sequencer: LANES must be a power of two, and LANES > 1 needs the window kernel (WINDOW > 0)");
    end
    if (IINV_W != 1 && IINV_W != 3 && IINV_W != 6) begin : g_bad_iinv
        $error("pgs_sequencer: IINV_W (inverse-inertia words per body) must be 1, 3 or 6");
    end
    if (MU_W != 0 && MU_W != 1) begin : g_bad_mu
        $error("pgs_sequencer: MU_W (friction-coefficient words per friction record) must be 0 or 1");
    end
    if (TANGENTS_ON_CHIP && (WINDOW > 0 || IINV_W != 3 || MU_W != 0)) begin : g_bad_tangents
        $error("pgs_sequencer: TANGENTS_ON_CHIP is a configuration of the streaming kernel (WINDOW = 0) with the diagonal inverse inertia (IINV_W = 3) and the constant friction coefficient (MU_W = 0)");
    end
    if (SOFT_CONTACT && (IINV_W != 3 || WINDOW > 0 || LANES > 1)) begin : g_bad_soft
        $error("pgs_sequencer: SOFT_CONTACT (the soft contact pipe) is built for IINV_W = 3 on the streaming kernel");
    end

    typedef enum logic [2:0] {S_IDLE, S_LOAD, S_SOLVE, S_DRAIN, S_INTEG, S_DONE} phase_t;
    phase_t phase;

    // ---------------- run arguments (sampled at start) ----------------
    logic [31:0] nb, nm;
    logic [ITER_W:0] iters, passes;   // passes = 2 * iterations
    logic        ilv;
    logic [31:0] r_lag, r_fetch;
    logic [W-1:0] r_dt, r_gx, r_gy, r_gz, r_damp;
    logic         r_soft;                 // SOFT_CONTACT: opt_soft and the keep factors of the run
    logic [W-1:0] r_keep_d, r_keep_s;
    // with the impulses in the records every fetch of the window kernel serves passes of one kind: fetch_passes
    // divides the iterations (contact passes, then friction passes), or 1 with the kinds interleaved
    logic mixed_fetch;
    always_comb begin
        mixed_fetch = 1'b0;
        for (int d = 1; d <= WINDOW_CTX; d++)
            if (arg_fetch_passes == 32'(d))
                mixed_fetch = opt_interleaved ? d != 1 : arg_iterations[ITER_W-1:0] % ITER_W'(d) != '0;
    end
    wire  bad_window = WINDOW > 0 && (arg_fetch_passes == 0 || arg_fetch_passes > 32'(WINDOW_CTX) || arg_lag == 0
                       || 64'(arg_fetch_passes - 1) * 64'(arg_lag) + 64'd2 > 64'(WINDOW)
                       || (IMPULSES_IN_RECORDS && mixed_fetch));
    wire  bad_args = arg_num_bodies > 32'(MAX_BODIES) || arg_num_manifolds > 32'(MAX_MANIFOLDS)
                     || arg_iterations >= 32'(1 << ITER_W) || bad_window
                     || (arg_num_manifolds & 32'(LANES - 1)) != 0;

    always_ff @(posedge clk) begin
        if (phase == S_IDLE && start) begin
            nb     <= arg_num_bodies;
            nm     <= arg_num_manifolds;
            iters  <= (ITER_W+1)'(arg_iterations[ITER_W-1:0]);
            passes <= {arg_iterations[ITER_W-1:0], 1'b0};
            ilv    <= opt_interleaved;
            r_lag  <= arg_lag;
            r_fetch <= arg_fetch_passes;
            r_dt   <= arg_dt;
            r_gx   <= arg_gx;
            r_gy   <= arg_gy;
            r_gz   <= arg_gz;
            r_damp <= arg_damping;
            r_soft <= opt_soft;
            r_keep_d <= arg_keep_dyn;
            r_keep_s <= arg_keep_static;
        end
    end

    function automatic logic kind_of(input logic [ITER_W:0] p, input logic il, input logic [ITER_W:0] it);
        return il ? p[0] : (p >= it);
    endfunction

    // ---------------- body RAM ----------------
    // port 2l: body A of lane l, port 2l + 1: body B (flat vectors, port k at [k*width +: width])
    localparam int PORTS = 2 * LANES;
    logic [PORTS*IDX_W-1:0]  rd_addr, wr_addr, dyn_addr;
    logic [PORTS-1:0]        rd_en;
    logic [PORTS*BREC_W-1:0] rd_data, wr_data;
    logic [PORTS-1:0]        wr_en, dyn, bad;
    logic                    wr0_full, wr0_bad, rd0_bad, body_busy;
    pgs_body_ram #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .MAX_BODIES(MAX_BODIES), .PORTS(PORTS),
                   .IINV_W(IINV_W), .BODY_BANKS(BODY_BANKS)) u_body_ram (.clk, .rd_en, .rd_addr, .rd_data, .rd0_bad, .wr_en,
        .wr0_full, .wr0_bad, .wr_addr, .wr_data, .dyn_addr, .dyn, .bad, .busy(body_busy));

    // ---------------- body-in stream ----------------
    // b_end: a TLAST was taken (no more body beats this step); b_fill: after an early TLAST, the missing
    // bodies are written as zero records, bad, one per cycle; b_flush: after the last body without TLAST,
    // beats are discarded up to TLAST.
    logic [B_BEATS*BODY_IN_W-1:0] brec;
    logic        brec_valid, brec_last, brec_trunc, b_done, b_done_trunc, b_unused_tag, b_asm_ready;
    logic        b_end, b_fill, b_flush;
    logic [31:0] b_asm_cnt, load_idx;
    pgs_record_asm #(.BEAT_W(BODY_IN_W), .MAX_BEATS(B_BEATS), .TAG_W(1)) u_body_asm (
        .clk, .rst, .enable(phase == S_LOAD && b_asm_cnt < nb && !b_end), .need(BNEED_W'(B_BEATS)),
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
    wire load_step  = phase == S_LOAD && (brec_valid || b_fill);   // body load_idx is written
    wire load_last  = load_step && load_idx == nb - 1;
    wire b_early    = phase == S_LOAD && brec_valid && brec_last && load_idx != nb - 1;
    wire b_late     = phase == S_LOAD && brec_valid && !brec_last && load_idx == nb - 1;

    // ---------------- constraint records: the stream pass by pass, or the record window ----------------
    // The record offered holds LANES manifold records of one pass (lane l: slot i_slot * LANES + l; the
    // streaming kernel has one lane). Per lane the issue logic reads bodies A and B, the spin-damping and shock
    // bits and the record's checks; stage 1 feeds the pass kind's words to the pipes (l_words).
    localparam int LREC_W = WR_BEATS * CONS_W;  // one lane's window record
    localparam int HB_W   = 2 * IDX_W + 5;      // head_of: what a lane's record gives its head
    // one lane's head in the window's ring: with the impulses in the records also whether its slot was rejected in
    // an earlier fetch (read from the rejected-slot flags as the record is written, below)
    localparam int HL_W   = HB_W + (IMPULSES_IN_RECORDS ? 1 : 0);

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

    logic            crec_tag;    // the record's pass kind
    logic            crec_valid, crec_trunc, take;
    logic            c_flush;     // discarding beats up to a TLAST
    logic            c_tlast_err; // error code 1 this cycle
    logic [ITER_W:0] i_pass;      // pass and record index of the record offered
    logic [31:0]     i_slot;
    logic            i_fill;      // rejecting the slots a pass is missing after an early TLAST, one per cycle
    wire  in_solve = phase == S_SOLVE;
    wire  slot_step;              // record i_slot of pass i_pass is done
    wire  [31:0] nm_rec = nm >> LG_L;  // records per pass
    wire  slot_last = i_slot == nm_rec - 1;

    logic [IDX_W-1:0]      la [LANES], lb [LANES];   // bodies A, B of each lane
    logic [LANES-1:0]      l_sd, l_empty_hdr, l_index, l_nonfinite;
    // a shock pass's header bits (the streaming kernel; the window kernel's records serve several passes: none)
    logic [LANES-1:0]      l_fa, l_fb, l_lin;
    logic [S1_WORDS*W-1:0] l_words [LANES];  // the pass kind's words (streaming: at issue; window: at stage 1)
    logic                  s1_kind;          // stage 1's pass kind (the lanes issue together)
    // window kernel: the candidate's ring address, whether its pass is the first / last of its fetch; the record
    // entering the ring's write (the next cycle): its slot, whether it is of the first fetch, and (impulses in the
    // records) per lane whether that slot was rejected in an earlier fetch; the candidate's head's such bit
    logic [RA_W-1:0]       w_addr;
    logic                  w_first, w_lastg;
    logic                  w_asm_move, w_asm_first;
    logic [31:0]           w_asm_slot;
    logic [LANES-1:0]      w_rej_q, w_head_seen;

    generate
        if (WINDOW == 0) begin : g_stream
            logic [CREC_W-1:0] crec;
            logic [ITER_W:0] a_pass;   // pass of the record being assembled
            logic [31:0]     a_slot;
            wire             a_kind = kind_of(a_pass, ilv, iters);
            wire             a_last = a_slot == nm - 1;
            logic            c_done, c_done_trunc, c_asm_ready, crec_last;
            pgs_record_asm #(.BEAT_W(CONS_W), .MAX_BEATS(CM_BEATS), .TAG_W(1)) u_cons_asm (
                .clk, .rst, .enable((phase == S_LOAD || phase == S_SOLVE) && a_pass < passes && nm != 0 && !c_flush),
                .need(a_kind ? CNEED_W'(F_BEATS) : CNEED_W'(C_BEATS)), .in_tag(a_kind),
                .s_tdata(s_cons_tdata), .s_tvalid(s_cons_tvalid), .s_tlast(s_cons_tlast), .s_tready(c_asm_ready),
                .done(c_done), .done_trunc(c_done_trunc), .rec_data(crec), .rec_tag(crec_tag), .rec_last(crec_last),
                .rec_trunc(crec_trunc), .rec_valid(crec_valid), .rec_ready(take));
            assign s_cons_tready = c_asm_ready || c_flush;
            wire c_pass_end = c_done && (a_last || s_cons_tlast);   // the assembler moves on to the next pass
            assign c_tlast_err = c_done && (s_cons_tlast != a_last || c_done_trunc);
            wire [63:0] hdr = crec[63:0];
            assign la[0]          = hdr[IDX_W-1:0];
            assign lb[0]          = hdr[32 +: IDX_W];
            assign l_sd[0]        = hdr[pgs_stream_layout_pkg::HEADER_SPIN_DAMP_BIT];
            assign l_empty_hdr[0] = 1'b0;
            assign l_index[0]     = index_bad(hdr[HIDX_W-1:0], nb);
            assign l_nonfinite[0] = nonfinite_of(crec, crec_tag);
            assign l_fa[0]        = hdr[pgs_stream_layout_pkg::HEADER_FROZEN_A_BIT];
            assign l_fb[0]        = hdr[pgs_stream_layout_pkg::HEADER_FROZEN_B_BIT];
            assign l_lin[0]       = hdr[pgs_stream_layout_pkg::HEADER_SHOCK_LINEAR_BIT];
            assign l_words[0]     = crec[64 +: S1_WORDS*W];
            assign w_addr  = '0;
            assign w_first = 1'b0;
            assign w_lastg = 1'b1;
            assign w_asm_move  = 1'b0;
            assign w_asm_first = 1'b1;
            assign w_asm_slot  = '0;
            assign w_head_seen = '0;
            wire unused_stream = ^{r_lag, r_fetch, crec[CREC_W-1:64 + S1_WORDS*W], w_rej_q};   // the window's, padding

            always_ff @(posedge clk) begin
                if (phase == S_IDLE) begin
                    a_pass  <= '0;
                    a_slot  <= '0;
                    c_flush <= 1'b0;
                    i_pass  <= '0;
                    i_slot  <= '0;
                    i_fill  <= 1'b0;
                end else begin
                    if (c_done) begin
                        if (c_pass_end) begin
                            a_slot <= '0;
                            a_pass <= a_pass + 1'b1;
                        end else begin
                            a_slot <= a_slot + 1;
                        end
                    end
                    if (c_done && a_last && !s_cons_tlast) c_flush <= 1'b1;
                    else if (c_flush && s_cons_tvalid && s_cons_tlast) c_flush <= 1'b0;
                    if (slot_step) begin
                        if (slot_last) begin
                            i_slot <= '0;
                            i_pass <= i_pass + 1'b1;
                            i_fill <= 1'b0;
                        end else begin
                            i_slot <= i_slot + 1;
                            if (take && crec_last) i_fill <= 1'b1;   // TLAST before the pass's last slot
                        end
                    end
                end
            end
        end else begin : g_window
            logic [LANES*LREC_W-1:0] wr_rec, rd_rec;
            logic [LANES*HL_W-1:0]   wr_head, whead;
            logic [ITER_W:0]   w_pass;
            logic              w_done, w_flush;
            logic [$clog2(WINDOW)-1:0] cand_addr;
            pgs_window #(.CONS_W(CONS_W), .REC_BEATS(LANES * WR_BEATS), .DEPTH(WINDOW), .CTX(WINDOW_CTX),
                         .PASS_W(ITER_W + 1), .HEAD_W(LANES * HL_W)) u_window (
                .clk, .rst, .init(phase == S_IDLE), .nm(nm_rec), .passes, .fetch_passes(r_fetch[ITER_W:0]),
                .lag(r_lag), .fetch_en(phase == S_LOAD || phase == S_SOLVE), .s_tdata(s_cons_tdata),
                .s_tvalid(s_cons_tvalid), .s_tready(s_cons_tready), .s_tlast(s_cons_tlast), .asm_move(w_asm_move),
                .asm_slot(w_asm_slot), .asm_first(w_asm_first), .wr_rec, .wr_head,
                .cand_valid(crec_valid), .cand_head(whead), .cand_addr, .cand_first(w_first), .cand_lastg(w_lastg),
                .cand_trunc(crec_trunc), .rd_rec, .cand_pass(w_pass), .cand_slot(i_slot), .take,
                .all_done(w_done), .flushing(w_flush), .tlast_err(c_tlast_err));
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
                    la[l]          = h[IDX_W-1:0];
                    lb[l]          = h[IDX_W +: IDX_W];
                    l_sd[l]        = h[2*IDX_W];
                    l_empty_hdr[l] = h[2*IDX_W + 1];
                    l_index[l]     = h[2*IDX_W + 2];
                    l_nonfinite[l] = crec_tag == FRICTION ? h[2*IDX_W + 4] : h[2*IDX_W + 3];
                    // stage 1: the words of the record taken in the issue cycle (the ring's registered read)
                    l_words[l]     = kind_view(rd_rec[l*LREC_W +: LREC_W], s1_kind)[64 +: S1_WORDS*W];
                end
            end
            assign l_fa      = '0;
            assign l_fb      = '0;
            assign l_lin     = '0;
            assign crec_tag  = kind_of(w_pass, ilv, iters);
            assign i_pass    = w_pass;
            assign i_fill    = 1'b0;
            assign c_flush   = w_flush;
            // the window ends the solve with the last pass's last record (solve_last); the padding of the lanes'
            // records and its all-done flag are not needed here
            logic unused_window;
            always_comb begin
                unused_window = ^{w_done, r_fetch[31:ITER_W+1]};
                for (int l = 0; l < LANES; l++)
                    unused_window ^= ^kind_view(rd_rec[l*LREC_W +: LREC_W], s1_kind)[CREC_W-1:64 + S1_WORDS*W];
            end
        end
    endgenerate

    // ---------------- issue ----------------
    // Every lane of the record offered issues in the same cycle, or none does: the record is taken when no
    // lane has to issue (all rejected or empty) or when no issuing lane's dynamic body is in flight
    // (pgs_hazard_cam). The lanes' manifolds must not share a dynamic body (the host's lane plan,
    // models/kernel/record_window.py, guarantees it); a lane that shares one with an earlier issuing lane is
    // rejected (error 4), so that no two lanes ever write one body.
    wire             rkind  = crec_tag;
    logic hazard, cam_full, cam_empty, retire, last_kind;
    wire  [ITER_W:0]   i_iter_full = ilv ? (i_pass >> 1) : (i_pass >= iters ? i_pass - iters : i_pass);
    wire  [ITER_W-1:0] i_iter = i_iter_full[ITER_W-1:0];
    // the streaming kernel with two pipes per lane drains a pipe before it switches kinds (retire in issue order; the
    // shared datapath takes both kinds at one latency, the window kernel aligns the two pipes' latencies) and every
    // kernel waits while a body-velocity bank is busy with the retire (BODY_BANKS > 0)
    wire  issue_ok  = (SHARED_DATAPATH || WINDOW > 0 || rkind == last_kind || cam_empty) && !body_busy;

    logic [31:0]       lslot [LANES];            // manifold slot of each lane
    always_comb begin
        for (int l = 0; l < LANES; l++) lslot[l] = i_slot * LANES + 32'(l);
    end

    // the issue checks of each lane's record. An all-ones header in the window kernel is an empty lane (the host's
    // padding): never issued, never rejected, no error. With banked body velocities and lanes, a lane that would
    // have the issuing lanes read some bank more than twice (its ports) is rejected like a lane sharing a dynamic
    // body (error 4; the host's lane plan keeps apart the manifolds that would: models/kernel/record_window.py): a record's
    // reads then fit the banks' ports, and so do its retire's writes (its dynamic bodies).
    localparam int BANK_W = BODY_BANKS > 1 ? $clog2(BODY_BANKS) : 1;
    /* verilator lint_off UNUSEDSIGNAL */  // b: a body's bank is its index's low bits
    function automatic logic [BANK_W-1:0] bank_of(input logic [IDX_W-1:0] b);
        return BODY_BANKS > 1 ? b[BANK_W-1:0] : '0;
    endfunction
    /* verilator lint_on UNUSEDSIGNAL */
    logic [LANES-1:0] l_rej_seen;   // slots rejected earlier in the step (written for every slot in pass 0)
    logic [LANES-1:0] l_empty, l_static, l_collide, l_rej, l_go;
    always_comb begin
        automatic logic [LANES-1:0] go = '0;   // the lanes so far that issue
        for (int l = 0; l < LANES; l++) begin
            automatic logic rej_prev = i_pass != '0 && l_rej_seen[l];
            automatic logic rej_bad;
            l_empty[l]  = WINDOW > 0 && !crec_trunc && l_empty_hdr[l];
            rej_bad     = !l_index[l] && (bad[2*l] || bad[2*l+1]);
            l_static[l] = !l_index[l] && !rej_bad && !dyn[2*l] && !dyn[2*l+1];
            l_collide[l] = 1'b0;
            for (int k = 0; k < l; k++) begin
                if (go[k] && ((dyn[2*l] && (la[l] == la[k] || la[l] == lb[k]))
                              || (dyn[2*l+1] && (lb[l] == la[k] || lb[l] == lb[k])))) l_collide[l] = 1'b1;
            end
            if (BODY_BANKS > 0 && LANES > 1) begin   // the reads of bodies A and B in their banks, earlier lanes'
                automatic int in_a = bank_of(la[l]) == bank_of(lb[l]) ? 2 : 1;
                automatic int in_b = in_a;
                for (int k = 0; k < l; k++) begin   // the earlier issuing lanes' reads
                    if (go[k]) begin
                        in_a += int'(bank_of(la[k]) == bank_of(la[l])) + int'(bank_of(lb[k]) == bank_of(la[l]));
                        in_b += int'(bank_of(la[k]) == bank_of(lb[l])) + int'(bank_of(lb[k]) == bank_of(lb[l]));
                    end
                end
                if (in_a > 2 || in_b > 2) l_collide[l] = 1'b1;
            end
            l_rej[l] = rej_prev || l_index[l] || rej_bad || l_static[l] || l_nonfinite[l] || crec_trunc
                       || l_collide[l];
            go[l]    = !l_empty[l] && !l_rej[l];
        end
        l_go = go;
    end
    logic imp_room;   // the impulse-out stream has room for one more record (always, on-chip impulses)
    assign take = in_solve && crec_valid && !i_fill && imp_room && (l_go == '0 || (!hazard && !cam_full && issue_ok));
    wire  [LANES-1:0] l_issue  = {LANES{take}} & l_go;
    wire  [LANES-1:0] l_reject = {LANES{take}} & ~l_empty & l_rej;
    wire  issue      = l_issue != '0;
    wire  fill       = in_solve && i_fill && imp_room;
    assign slot_step = take || fill;
    // the rejected-slot flags: one bit per slot, written at its take in pass 0 and when a later pass rejects it, read
    // for the record offered. The streaming kernel reads them at a registered slot index (block RAM on a board). The
    // window kernel (per lane, indexed by the record index): with the impulses in the records, as each record is
    // written into the ring (a registered read, block RAM; the bit rides in the record's head): every pass of the
    // slot's earlier fetches has taken it by then (the DMA reads fetch f's record only after fetch f - 1's last pass
    // wrote its impulses), and the passes of one fetch read the same record, so they decide alike; with the impulses
    // on chip at the offered pass's slot, a selection of the pass contexts (an asynchronous read, LUT RAM).
    generate
        if (WINDOW == 0) begin : g_rej_stream
            logic slot_rej [MAX_MANIFOLDS];
            assign l_rej_seen[0] = slot_rej[i_slot[SLOT_W-1:0]];
            always_ff @(posedge clk) begin
                if (slot_step && (i_pass == '0 || l_reject[0] || fill)) slot_rej[i_slot[SLOT_W-1:0]] <= l_reject[0] || fill;
            end
            assign w_rej_q = '0;
        end else if (IMPULSES_IN_RECORDS) begin : g_rej_ring
            for (genvar l = 0; l < LANES; l++) begin : g_lane_rej
                pgs_ring_ram #(.WIDTH(1), .DEPTH(MAX_MANIFOLDS / LANES), .SYNC_READ(1'b1)) u_slot_rej (
                    .clk, .wr_en(slot_step && (i_pass == '0 || l_reject[l])), .wr_addr(i_slot[BSLOT_W-1:0]),
                    .wr_data(l_reject[l]), .rd_en(w_asm_move), .rd_addr(w_asm_slot[BSLOT_W-1:0]),
                    .rd_data(w_rej_q[l]));
            end
            assign l_rej_seen = w_head_seen;
        end else begin : g_rej_window
            for (genvar l = 0; l < LANES; l++) begin : g_lane_rej
                pgs_ring_ram #(.WIDTH(1), .DEPTH(MAX_MANIFOLDS / LANES), .SYNC_READ(1'b0)) u_slot_rej (
                    .clk, .wr_en(slot_step && (i_pass == '0 || l_reject[l])), .wr_addr(i_slot[BSLOT_W-1:0]),
                    .wr_data(l_reject[l]), .rd_en(1'b0), .rd_addr(i_slot[BSLOT_W-1:0]), .rd_data(l_rej_seen[l]));
            end
            assign w_rej_q = '0;
        end
    endgenerate

    logic [2*LANES*IDX_W-1:0] cand;
    logic [2*LANES-1:0]       cand_dyn;
    always_comb begin
        for (int l = 0; l < LANES; l++) begin
            cand[2*l*IDX_W +: IDX_W]     = la[l];
            cand[(2*l+1)*IDX_W +: IDX_W] = lb[l];
            cand_dyn[2*l]   = dyn[2*l] && l_go[l];
            cand_dyn[2*l+1] = dyn[2*l+1] && l_go[l];
        end
    end
    pgs_hazard_cam #(.IDX_W(IDX_W), .DEPTH(HAZARD_DEPTH), .NB(2*LANES)) u_cam (
        .clk, .rst, .cand, .cand_dyn, .hazard, .push(issue), .pop(retire), .full(cam_full), .empty(cam_empty));
    assign dyn_addr = cand;

    // ---------------- the lanes: impulse RAM bank, stage 1, the datapath (pgs_lane_datapath), retire ----------------
    // Lane l holds the slots l, l + LANES, ...: its impulse RAM bank is indexed by the record index.
    // Every manifold retires the lane datapath's LATENCY + 1 cycles after its issue with the shared datapath and in
    // the window kernel (its two pipes aligned to the contact pipe's latency), so the lanes of an issue retire
    // together and one CAM entry leaves.
    logic [LANES-1:0]       l_retire, l_fret, l_dyn_a, l_dyn_b;
    logic [IDX_W-1:0]       l_ra [LANES], l_rb [LANES];
    logic [12*W-1:0]        l_vel [LANES];             // vA wA vB wB
    logic [4*W-1:0]         l_imp [LANES];
    logic [SLOT_W-1:0]      l_rslot [LANES];
    logic [ITER_W-1:0]      l_riter [LANES];
    logic [RA_W-1:0]        l_raddr [LANES];           // window kernel: the retiring record's ring address
    logic [LANES-1:0]       l_rlastg;                  // ... its pass is the last of its fetch
    logic [3*EV_W-1:0]      l_ev [LANES];              // {invalid, underflow, overflow} of the lane's datapath
    always_ff @(posedge clk) begin
        if (issue) s1_kind <= rkind;
    end
    for (genvar l = 0; l < LANES; l++) begin : g_lane
        logic [4*W-1:0] rd_lam;
        logic [2*W-1:0] rd_lamT;
        // stage 1: the record and tag of the manifold issued in the previous cycle. A shock pass's row (header bits
        // frozen A / B, linear; models/golden/shock_propagation.py, streaming kernel only) takes its frozen body as a static
        // one: its inverse mass and inertia enter the pipe as 0 and its tag's dynamic bit is clear, so retire does
        // not write it (the CAM holds it as issued: the hazards, and so the cycles, are those of the same schedule
        // without the bits); a linear row's inverse inertias enter as 0 and its spin damping is off.
        logic              s1_valid, s1_sd, s1_fa, s1_fb, s1_lin;
        logic [S1_WORDS*W-1:0] s1_words;
        if (IMPULSES_IN_RECORDS) begin : g_imp_rec
            // the impulses the pass starts from are the record's last words (host-given or the last pass's). The
            // window kernel's record serves every pass of its fetch (of one kind): the fetch's first pass reads the
            // record's, every later pass what the pass before wrote into the impulse ring (the ring address's
            // lam[0..3] after a contact pass, lamT[0..1] after a friction pass: read at issue, written at retire,
            // a record of a later pass issuing only after that retire); a friction pass's lam (its friction limit,
            // the contact passes' result) is the record's.
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
                    .clk, .wr_en(l_retire[l]), .wr_addr(l_raddr[l]), .wr_data(l_imp[l]), .rd_en(l_issue[l]),
                    .rd_addr(w_addr), .rd_data(ring_imp));
                always_ff @(posedge clk) begin
                    if (l_issue[l]) s1_first <= w_first;
                end
            end else begin : g_no_imp_ring
                assign ring_imp = '0;
                assign s1_first = 1'b1;
            end
            assign rd_lam  = s1_kind == CONTACT && !s1_first ? ring_imp : rec_lam;
            assign rd_lamT = s1_first ? rec_lamT : ring_lamT;
            wire unused_ring = ^ring_imp[4*W-1:2*W];
        end else begin : g_imp_ram
            wire [BSLOT_W-1:0] wr_rec = BSLOT_W'(l_rslot[l] >> LG_L);
            pgs_impulse_ram #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .MAX_MANIFOLDS(MAX_MANIFOLDS / LANES)) u_imp_ram (
                .clk, .rd_addr(i_slot[BSLOT_W-1:0]), .rd_zero_lam(rkind == CONTACT && i_iter == '0),
                .rd_zero_lamT(rkind == FRICTION && i_iter == '0), .rd_lam, .rd_lamT, .wr_addr(wr_rec),
                .wr_lam_en(l_retire[l] && l_fret[l] == CONTACT), .wr_lam(l_imp[l]),
                .wr_lamT_en(l_retire[l] && l_fret[l] == FRICTION), .wr_lamT(l_imp[l][0 +: 2*W]));
        end
        logic [STAG_W-1:0] s1_tag;
        always_ff @(posedge clk) begin
            if (rst) s1_valid <= 1'b0;
            else     s1_valid <= l_issue[l];
        end
        always_ff @(posedge clk) begin
            if (l_issue[l]) begin
                s1_sd    <= l_sd[l] && !l_lin[l];
                s1_fa    <= l_fa[l];
                s1_fb    <= l_fb[l];
                s1_lin   <= l_lin[l];
                s1_tag   <= STAG_W'({w_lastg, w_addr, lslot[l][SLOT_W-1:0], i_iter, la[l], lb[l], dyn[2*l] && !l_fa[l],
                                     dyn[2*l+1] && !l_fb[l]});
            end
        end
        // the pass kind's words: the streaming kernel registers the record at issue, the window kernel's ring read
        // of the record taken at issue is registered already
        if (WINDOW == 0) begin : g_s1_words
            always_ff @(posedge clk) begin
                if (l_issue[l]) s1_words <= l_words[l];
            end
        end else begin : g_s1_ring
            assign s1_words = l_words[l];
        end

        // body fields of the stage-1 reads (A on port 2l, B on port 2l + 1)
        wire [BREC_W-1:0] ra = rd_data[2*l*BREC_W +: BREC_W];
        wire [BREC_W-1:0] rb = rd_data[(2*l+1)*BREC_W +: BREC_W];
        // the bodies' mass words as the datapath takes them: 0 for a frozen body, no inverse inertia on a linear row
        wire [W-1:0]        m_a = s1_fa ? '0 : ra[13*W +: W];
        wire [W-1:0]        m_b = s1_fb ? '0 : rb[13*W +: W];
        wire [IINV_W*W-1:0] i_a = s1_fa || s1_lin ? '0 : ra[14*W +: IINV_W*W];
        wire [IINV_W*W-1:0] i_b = s1_fb || s1_lin ? '0 : rb[14*W +: IINV_W*W];
        logic              r_valid, r_kind;
        logic [STAG_W-1:0] r_tag;
        logic [4*W-1:0]    r_imp;
        logic [12*W-1:0]   r_vel;
        logic [EV_W-1:0]   ev_ovf, ev_unf, ev_inv;
        pgs_lane_datapath #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .TAG_W(STAG_W), .IINV_W(IINV_W), .MU_W(MU_W),
                            .TANGENTS_ON_CHIP(TANGENTS_ON_CHIP), .SOFT_CONTACT(SOFT_CONTACT),
                            .SHARED_DATAPATH(SHARED_DATAPATH), .ALIGN(WINDOW > 0),
                            .DELAY_BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH)) u_datapath (
            .clk, .rst, .in_valid(s1_valid), .in_kind(s1_kind), .in_tag(s1_tag), .in_rec(s1_words[0 +: 23*W]),
            .in_lam(rd_lam), .in_lamT(rd_lamT), .in_xa(ra[0 +: 3*W]), .in_xb(rb[0 +: 3*W]), .in_vwa(ra[7*W +: 6*W]),
            .in_vwb(rb[7*W +: 6*W]), .in_ma(m_a), .in_mb(m_b), .in_ia(i_a), .in_ib(i_b), .in_spin_damp(s1_sd),
            .in_soft(r_soft), .in_keep_dyn(r_keep_d), .in_keep_static(r_keep_s), .out_valid(r_valid),
            .out_kind(r_kind), .out_tag(r_tag), .out_imp(r_imp), .out_vel(r_vel), .ev_overflow(ev_ovf),
            .ev_underflow(ev_unf), .ev_invalid(ev_inv));

        // retire
        assign l_retire[l] = r_valid;
        assign l_fret[l]   = r_kind;
        assign l_vel[l]    = r_vel;
        assign l_imp[l]    = r_imp;
        assign l_dyn_b[l]  = r_tag[0];
        assign l_dyn_a[l]  = r_tag[1];
        assign l_rb[l]     = r_tag[2 +: IDX_W];
        assign l_ra[l]     = r_tag[2 + IDX_W +: IDX_W];
        assign l_riter[l]  = r_tag[2 + 2*IDX_W +: ITER_W];
        assign l_rslot[l]  = r_tag[2 + 2*IDX_W + ITER_W +: SLOT_W];
        if (WTAG_W > 0) begin : g_rtag_window
            assign l_raddr[l]  = r_tag[2 + 2*IDX_W + ITER_W + SLOT_W +: RA_W];
            assign l_rlastg[l] = r_tag[STAG_W-1];
        end else begin : g_rtag_stream
            assign l_raddr[l]  = '0;
            assign l_rlastg[l] = 1'b1;   // the streaming kernel: every pass writes its impulses out
        end
        assign l_ev[l]     = {ev_inv, ev_unf, ev_ovf};
        // the lane's slot bits of the record index, body B's orientation and the padding are not needed here
        wire unused_lane = ^{l_rslot[l], ra[7*W-1:3*W], rb[7*W-1:3*W]};
    end
    assign retire = l_retire != '0;

    // ---------------- impulse-out stream (IMPULSES_IN_RECORDS) ----------------
    // One record per slot of every pass (the window kernel: of the last pass of every fetch, which pgs_window keeps
    // from overlapping the next fetch's last pass; one record per window record, its lanes' words one after the
    // other), in slot order, TLAST on each pass's last slot: the updated
    // impulses of a retired manifold-pass (contact: lam[0..3]; friction: lamT[0..1], then two zero words; the
    // trace record's first four words), all zeros for a rejected slot or lane and an empty lane. The order FIFO
    // takes every such slot at its take ({last, rejected}), the data FIFO every such retire; a record leaves
    // when its order entry is at the head and, unless rejected, its retire has arrived. A slot is taken only with
    // room in the order FIFO (the pipes have no backpressure), so a stalled stream stalls the issue.
    logic imp_idle;   // no impulse-out record pending
    generate
        if (IMPULSES_IN_RECORDS) begin : g_imp_out
            logic [1:0]     ord_head;
            logic [LANES*4*W-1:0] dat_head, dat_in;
            logic           ord_empty, ord_full, dat_empty, dat_full;
            wire            imp_hs  = m_imp_tvalid && m_imp_tready;
            wire            ord_rej = ord_head[0];
            always_comb begin
                for (int l = 0; l < LANES; l++) dat_in[l*4*W +: 4*W] = l_retire[l] ? l_imp[l] : '0;
            end
            pgs_fifo #(.DATA_W(2), .DEPTH(IMP_FIFO_DEPTH)) u_imp_order (
                .clk, .rst, .push(slot_step && w_lastg), .push_data({slot_last, !issue}), .pop(imp_hs),
                .head(ord_head), .empty(ord_empty), .full(ord_full));
            pgs_fifo #(.DATA_W(LANES*4*W), .DEPTH(IMP_FIFO_DEPTH)) u_imp_data (
                .clk, .rst, .push(retire && (l_rlastg & l_retire) != '0), .push_data(dat_in),
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
            wire unused_imp = m_imp_tready;
        end
    endgenerate

    // body RAM ports: LOAD writes whole records on port 0; SOLVE retire writes v/w of lane l's A (port 2l)
    // and B (port 2l + 1), and reads the bodies of the offered record's issuing lanes; INTEG reads on port 0
    logic [31:0] int_idx;
    always_comb begin
        wr_en    = '0;
        wr0_full = 1'b0;
        wr0_bad  = 1'b0;
        wr_data  = '0;
        rd_addr  = cand;
        for (int l = 0; l < LANES; l++) rd_en[2*l +: 2] = {2{l_go[l]}};
        if (phase == S_INTEG) rd_en[0] = 1'b1;
        for (int l = 0; l < LANES; l++) begin
            wr_en[2*l]   = l_retire[l] && l_dyn_a[l];
            wr_en[2*l+1] = l_retire[l] && l_dyn_b[l];
            wr_addr[2*l*IDX_W +: IDX_W]     = l_ra[l];
            wr_addr[(2*l+1)*IDX_W +: IDX_W] = l_rb[l];
            wr_data[2*l*BREC_W + 7*W +: 6*W]     = l_vel[l][0 +: 6*W];
            wr_data[(2*l+1)*BREC_W + 7*W +: 6*W] = l_vel[l][6*W +: 6*W];
        end
        if (phase == S_LOAD) begin
            wr_en[0]  = load_step;
            wr0_full  = 1'b1;
            wr0_bad   = b_fill || brec_nonfinite || brec_bad_mass || brec_trunc;
            wr_addr[0 +: IDX_W] = load_idx[IDX_W-1:0];
            wr_data[0 +: BREC_W] = b_fill ? '0 : brec[0 +: BREC_W];
        end
        if (phase == S_INTEG) rd_addr[0 +: IDX_W] = int_idx[IDX_W-1:0];
    end
    wire [BREC_W-1:0] rd0_data = rd_data[0 +: BREC_W];

    generate
        if (TRACE) begin : g_trace
            always_comb begin
                trace_valid = l_retire;
                trace_data  = '0;
                for (int l = 0; l < LANES; l++) begin
                    trace_data[l*TRACE_W +: 4*W]             = l_imp[l];
                    trace_data[l*TRACE_W + 4*W +: 12*W]      = l_vel[l];
                    trace_data[l*TRACE_W + 16*W +: 32]       = 32'(l_rslot[l]);
                    trace_data[l*TRACE_W + 16*W + 32 +: 16]  = l_riter[l];
                    trace_data[l*TRACE_W + 16*W + 48]        = l_fret[l];
                end
            end
        end else begin : g_no_trace
            assign trace_valid = '0;
            assign trace_data  = '0;
            // the retire fields only feed the trace
            logic unused_trace;
            always_comb begin
                unused_trace = ^l_fret;
                for (int l = 0; l < LANES; l++) unused_trace ^= ^{l_riter[l], l_imp[l]};
            end
        end
    endgenerate

    // ---------------- integration and body-out ----------------
    logic [31:0] credits;        // bodies in the integrate pipe or in the output FIFO
    logic [31:0] out_cnt;        // body-out records completely sent
    logic [OBEAT_W-1:0] out_beat;
    wire  int_issue = phase == S_INTEG && int_idx < nb && credits < 32'(OUT_FIFO_DEPTH);
    logic i1_valid;
    always_ff @(posedge clk) begin
        if (rst) i1_valid <= 1'b0;
        else     i1_valid <= int_issue;
    end
    // static (mInv == 0 after flush) and bad bodies pass through unchanged; their events are not counted
    wire i1_static = rd0_data[13*W + MAN_BITS +: EXP_BITS] == '0 || rd0_bad;
    wire [18*W-1:0] i_in = {r_gz, r_gy, r_gx, r_damp, r_dt, rd0_data[0 +: OREC_W]};
    logic              io_valid;
    logic [ITAG_W-1:0] io_tag;
    logic [EV_W-1:0]   i_ev_ovf, i_ev_unf, i_ev_inv;
    logic [OREC_W-1:0] io_data;
    pgs_integrate_pipe #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .TAG_W(ITAG_W),
                         .DELAY_BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH)) u_integrate (
        .clk, .rst, .in_valid(i1_valid), .in_tag({i1_static, rd0_data[0 +: OREC_W]}), .in_data(i_in),
        .in_count(!i1_static), .out_valid(io_valid), .out_tag(io_tag), .out_data(io_data), .ev_overflow(i_ev_ovf),
        .ev_underflow(i_ev_unf), .ev_invalid(i_ev_inv));

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

    // ---------------- phase machine and counters ----------------
    wire solve_last = slot_step && i_pass == passes - 1 && slot_last;
    wire solve_work = nm != 0 && passes != 0;

    always_ff @(posedge clk) begin
        if (rst) begin
            phase <= S_IDLE;
        end else begin
            unique case (phase)
                S_IDLE:  if (start) phase <= bad_args ? S_DONE : (arg_num_bodies != 0 ? S_LOAD : S_INTEG);
                // LOAD ends with the last body written and no extra body beats left to discard
                S_LOAD:  if ((load_last || load_idx == nb) && !b_flush && !b_late)
                             phase <= solve_work ? S_SOLVE : S_INTEG;
                S_SOLVE: if (solve_last) phase <= S_DRAIN;
                S_DRAIN: if (cam_empty && !c_flush) phase <= S_INTEG;
                // (and, with IMPULSES_IN_RECORDS, the last impulse-out record taken)
                S_INTEG: if (((out_pop && out_cnt == nb - 1) || nb == 0 || out_cnt == nb) && imp_idle) phase <= S_DONE;
                S_DONE:  phase <= S_IDLE;
                default: phase <= S_IDLE;
            endcase
        end
    end
    assign idle = phase == S_IDLE;
    assign done = phase == S_DONE;

    logic [LANES*3*EV_W-1:0] lane_ev;
    always_comb begin
        for (int l = 0; l < LANES; l++) lane_ev[3*EV_W*l +: 3*EV_W] = l_ev[l];
    end

    // run statistics and the datapaths' floating-point events (each pipe reports the previous cycle's; they
    // arrive at most LATENCY + 1 cycles after an input, before the step's last body-out beat)
    pgs_run_counters #(.LANES(LANES), .EV_W(EV_W)) u_counters (
        .clk, .rst, .idle, .start, .stall(in_solve && crec_valid && !i_fill && !take),
        .bubble(in_solve && !crec_valid && !i_fill), .issued(l_issue), .rejected(l_reject), .fill_rejected(fill),
        .lane_ev, .int_ev_ovf(i_ev_ovf), .int_ev_unf(i_ev_unf), .int_ev_inv(i_ev_inv), .fp_set, .stat_cycles,
        .stat_stalls, .stat_bubbles, .stat_issued, .stat_rejected, .stat_fp_overflow, .stat_fp_underflow,
        .stat_fp_invalid);

    // counters of the phases (no reset needed beyond the start of a run)
    always_ff @(posedge clk) begin
        if (phase == S_IDLE) begin
            b_asm_cnt <= '0;
            load_idx  <= '0;
            b_end     <= 1'b0;
            b_fill    <= 1'b0;
            b_flush   <= 1'b0;
            last_kind <= CONTACT;
            int_idx   <= '0;
            credits   <= '0;
            out_cnt   <= '0;
            out_beat  <= '0;
        end else begin
            if (b_done) b_asm_cnt <= b_asm_cnt + 1;
            if (b_done && s_body_tlast) b_end <= 1'b1;
            if (load_step) load_idx <= load_idx + 1;
            if (b_early) b_fill <= 1'b1;
            else if (load_last) b_fill <= 1'b0;
            if (b_late) b_flush <= 1'b1;
            else if (b_flush && s_body_tvalid && s_body_tlast) b_flush <= 1'b0;
            if (issue) last_kind <= rkind;
            if (int_issue) int_idx <= int_idx + 1;
            credits <= credits + 32'(int_issue) - 32'(out_pop);
            if (out_hs) out_beat <= out_pop ? '0 : out_beat + 1'b1;
            if (out_pop) out_cnt <= out_cnt + 1;
        end
    end

    // ---------------- errors ----------------
    // the conditions of codes 1..7 this cycle, encoded into err_set / err_code by pgs_error_flags.
    // A record cut short by TLAST (code 1 / 2) holds stale words: its other checks raise nothing.
    wire [LANES-1:0] cons_check = {LANES{take && !crec_trunc}} & ~l_empty;
    wire body_in_check = phase == S_LOAD && brec_valid && !brec_trunc;
    pgs_error_flags u_errors (
        .cons_tlast(c_tlast_err),
        .body_tlast(b_done && (s_body_tlast != (b_asm_cnt == nb - 1) || b_done_trunc)),
        .bad_args(phase == S_IDLE && start && bad_args),
        .body_index((cons_check & (l_index | l_collide)) != '0),
        .non_finite((cons_check & l_nonfinite) != '0 || (body_in_check && brec_nonfinite)),
        .negative_mass(body_in_check && brec_bad_mass),
        .static_pair((cons_check & l_static) != '0),
        .err_set, .err_code);

    // Not needed (Verilator's *unused* naming convention): the FIFO never fills (an integration issues
    // only with a free credit); the body-in assembler carries no tag; the padding bits of the records;
    // body B's orientation.
    logic unused_seq;
    always_comb begin
        unused_seq = ^{i_iter_full[ITER_W], ofifo_full, b_unused_tag, brec, rd0_data, bad};
        if (!SOFT_CONTACT) unused_seq ^= ^{r_soft, r_keep_d, r_keep_s};   // the rigid kernel reads no keep factor
        if (!IMPULSES_IN_RECORDS) unused_seq ^= w_first;   // the impulse ring's source select
        // the ring write's slot and the rejected bit of the heads: the window kernel with the impulses in the records
        if (WINDOW == 0 || !IMPULSES_IN_RECORDS) unused_seq ^= ^{w_asm_move, w_asm_first, w_asm_slot, w_head_seen};
        else unused_seq ^= ^w_asm_slot[31:BSLOT_W];
        for (int l = 0; l < LANES; l++) unused_seq ^= ^{lslot[l][31:SLOT_W], l_raddr[l], l_rlastg[l]};
    end
endmodule

`default_nettype wire
