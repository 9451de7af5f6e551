// AXI4-Stream source fed a whole burst at a time, for transaction-level co-simulation.
//
// The testbench writes up to BURST beats at once (burst_data, beat k in bits [k*W +: W]; burst_last; burst_beats)
// and then changes burst_seq; the source loads the burst into its buffer when the buffer is empty or its last beat
// is being presented, reports the load on taken_seq (= the loaded burst_seq), and presents the beats with no
// testbench activity per beat: the testbench wakes once per burst, on a change of taken_seq. A new beat is
// presented when the output register is free and `allow` (the DDR credit of this cycle) is high; `take` says so
// (the credit is spent on it). busy: beats buffered, a burst pending or a beat on the bus.
`default_nettype none
module axis_burst_source #(
    parameter int W     = 512,
    parameter int BURST = 16
) (
    input  wire               clk,
    input  wire               rst_n,
    input  wire [BURST*W-1:0] burst_data,
    input  wire [BURST-1:0]   burst_last,
    input  wire [15:0]        burst_beats,
    input  wire [31:0]        burst_seq,
    output logic [31:0]       taken_seq,
    output logic              busy,
    input  wire               allow,
    output logic              take,
    output logic [W-1:0]      tdata,
    output logic              tvalid,
    output logic              tlast,
    input  wire               tready
);
    logic [W-1:0]     buf_data [BURST];
    logic [BURST-1:0] buf_last;
    logic [15:0]      count;  // beats in the buffer
    logic [15:0]      idx;    // the next beat to present

    wire have    = idx != count;
    wire pending = burst_seq != taken_seq;
    wire free    = !tvalid || tready;
    assign take = free && have && allow;
    wire load    = pending && (!have || (take && idx == count - 16'd1));
    assign busy = have || pending || tvalid;

    always_ff @(posedge clk) begin
        if (!rst_n) begin
            tvalid    <= 1'b0;
            tlast     <= 1'b0;
            count     <= '0;
            idx       <= '0;
            taken_seq <= burst_seq;
        end else begin
            if (take) begin
                tdata  <= buf_data[idx[$clog2(BURST)-1:0]];
                tlast  <= buf_last[idx[$clog2(BURST)-1:0]];
                tvalid <= 1'b1;
                idx    <= idx + 16'd1;
            end else if (tready) begin
                tvalid <= 1'b0;
            end
            if (load) begin
                for (int k = 0; k < BURST; k++) buf_data[k] <= burst_data[k*W +: W];
                buf_last  <= burst_last;
                count     <= burst_beats;
                idx       <= '0;
                taken_seq <= burst_seq;
            end
        end
    end
endmodule
`default_nettype wire
