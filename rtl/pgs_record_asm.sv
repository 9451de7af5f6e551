// pgs_record_asm: assembles AXI4-Stream beats into records of `need` beats (beat j of a record at
// record bits [j*BEAT_W +: BEAT_W], the packing of models/kernel/stream_format.py) and hands complete
// records on through a valid/ready register.
//
// Beats are accepted only while `enable`; `need` (1..MAX_BEATS) may change between records (the
// kernel derives it from the pass the next record belongs to); `in_tag` is captured with the final
// beat of a record and travels with it (rec_tag); rec_last is that beat's TLAST. `done` pulses when
// the final beat of a record is accepted. A beat with TLAST ends the record even when it is not the
// `need`-th: the record is then truncated (done_trunc with done, rec_trunc with the record; its missing
// beats hold stale data), so a stream that is shorter than programmed never leaves the assembler
// waiting for beats of the next stream. Throughput: one beat per cycle, so one record per `need`
// cycles (one accumulation register plus the output register).
`default_nettype none

module pgs_record_asm #(
    parameter int BEAT_W    = 128,
    parameter int MAX_BEATS = 5,
    parameter int TAG_W     = 1,
    localparam int NEED_W   = $clog2(MAX_BEATS + 1),
    localparam int REC_W    = MAX_BEATS * BEAT_W
) (
    input  wire               clk,
    input  wire               rst,
    input  wire               enable,
    input  wire  [NEED_W-1:0] need,
    input  wire  [TAG_W-1:0]  in_tag,
    input  wire  [BEAT_W-1:0] s_tdata,
    input  wire               s_tvalid,
    input  wire               s_tlast,
    output logic              s_tready,
    output logic              done,
    output logic              done_trunc,
    output logic [REC_W-1:0]  rec_data,
    output logic [TAG_W-1:0]  rec_tag,
    output logic              rec_last,
    output logic              rec_trunc,
    output logic              rec_valid,
    input  wire               rec_ready
);
    logic [BEAT_W-1:0] acc [MAX_BEATS];
    logic [NEED_W-1:0] cnt;
    logic              acc_full;
    logic [TAG_W-1:0]  acc_tag;
    logic              acc_last, acc_trunc;

    wire move   = acc_full && (!rec_valid || rec_ready);
    assign s_tready = enable && (!acc_full || move);
    wire accept = s_tvalid && s_tready;
    wire full_beat  = cnt == need - 1'b1;
    wire final_beat = accept && (full_beat || s_tlast);
    assign done       = final_beat;
    assign done_trunc = final_beat && !full_beat;

    always_ff @(posedge clk) begin
        if (rst) begin
            cnt       <= '0;
            acc_full  <= 1'b0;
            rec_valid <= 1'b0;
        end else begin
            if (accept) cnt <= final_beat ? '0 : cnt + 1'b1;
            if (final_beat) acc_full <= 1'b1;
            else if (move) acc_full <= 1'b0;
            if (move) rec_valid <= 1'b1;
            else if (rec_ready) rec_valid <= 1'b0;
        end
    end

    always_ff @(posedge clk) begin
        for (int j = 0; j < MAX_BEATS; j++) begin
            if (accept && cnt == NEED_W'(j)) acc[j] <= s_tdata;
        end
        if (final_beat) begin
            acc_tag  <= in_tag;
            acc_last  <= s_tlast;
            acc_trunc <= !full_beat;
        end
        if (move) begin
            for (int j = 0; j < MAX_BEATS; j++) rec_data[j*BEAT_W +: BEAT_W] <= acc[j];
            rec_tag  <= acc_tag;
            rec_last  <= acc_last;
            rec_trunc <= acc_trunc;
        end
    end
endmodule

`default_nettype wire
