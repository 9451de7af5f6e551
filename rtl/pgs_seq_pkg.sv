// pgs_seq_pkg: what the sequencer's modules (rtl/pgs_seq_*.sv, rtl/pgs_sequencer.sv) derive alike from the kernel's
// parameters: the words a constraint record carries after its header (models/kernel/stream_format.py, through the
// generated pgs_stream_layout_pkg), the beats a record takes, the pass kinds, the widths of the counters.
`default_nettype none

package pgs_seq_pkg;

    localparam bit CONTACT  = 1'b0;   // a record's pass kind
    localparam bit FRICTION = 1'b1;
    localparam int ITER_W   = 16;     // an iteration count (iterations < 2^16)
    localparam int EV_W     = 16;     // the datapaths' event counts per cycle

    // words of a contact record after the header: n, p[0..3], jac_inv, b, with the impulses in the records lam[0..3]
    function automatic int contact_words(input bit impulses_in_records);
        return pgs_stream_layout_pkg::CONTACT_WORDS
               + (impulses_in_records ? pgs_stream_layout_pkg::CONTACT_IMPULSE_WORDS : 0);
    endfunction

    // words of a friction record after the header: its words up to the impulses (MU_W, TANGENTS_ON_CHIP), with the
    // impulses in the records lam[0..3] and lamT[0..1]
    function automatic int friction_words(input int mu_w, input bit tangents_on_chip, input bit impulses_in_records);
        return pgs_stream_layout_pkg::friction_words(mu_w, tangents_on_chip)
               + (impulses_in_records ? pgs_stream_layout_pkg::FRICTION_IMPULSE_WORDS : 0);
    endfunction

    // the record words a lane's stage 1 holds: the longer kind's
    function automatic int stage_words(input int mu_w, input bit tangents_on_chip, input bit impulses_in_records);
        return contact_words(impulses_in_records) > friction_words(mu_w, tangents_on_chip, impulses_in_records)
               ? contact_words(impulses_in_records) : friction_words(mu_w, tangents_on_chip, impulses_in_records);
    endfunction

    // stream beats of a record of `words` words of w bits after the 64-bit header
    function automatic int record_beats(input int words, input int w, input int beat_w);
        return (pgs_stream_layout_pkg::HEADER_BITS + words * w + beat_w - 1) / beat_w;
    endfunction

    // the pass kind of pass p: interleaved (il) contact and friction passes, or the contact passes first
    function automatic logic kind_of(input logic [ITER_W:0] p, input logic il, input logic [ITER_W:0] it);
        return il ? p[0] : (p >= it);
    endfunction

endpackage

`default_nettype wire
