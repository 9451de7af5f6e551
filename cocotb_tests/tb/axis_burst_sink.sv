// AXI4-Stream sink that hands whole bursts to the testbench, for transaction-level co-simulation.
//
// While `enable` is high (a transfer armed) and `allow` (the DDR credit of this cycle) holds, TREADY is high until
// `limit` beats have been taken since enable rose; `take` marks a beat that moves (its credit is spent). Beats
// are collected into burst_data (beat k in bits [k*W +: W]); a burst closes at BURST beats, at TLAST or at the
// limit, and then burst_seq changes, with burst_beats and burst_last (it ended with TLAST) beside it. The
// testbench wakes once per burst, on that change, and reads burst_data in the same time step (the next beat
// overwrites beat 0 at the next clock edge).
`default_nettype none
module axis_burst_sink #(
    parameter int W     = 128,
    parameter int BURST = 16
) (
    input  wire                clk,
    input  wire                rst_n,
    input  wire                enable,
    input  wire [31:0]         limit,
    input  wire                allow,
    output logic               take,
    input  wire [W-1:0]        tdata,
    input  wire                tvalid,
    input  wire                tlast,
    output logic               tready,
    output logic [BURST*W-1:0] burst_data,
    output logic [15:0]        burst_beats,
    output logic               burst_last,
    output logic [31:0]        burst_seq
);
    logic [15:0] fill;   // beats of the open burst
    logic [31:0] taken;  // beats since enable rose

    assign tready = enable && allow && taken != limit;
    assign take   = tvalid && tready;
    wire close    = tlast || fill == 16'(BURST - 1) || taken + 32'd1 == limit;

    always_ff @(posedge clk) begin
        if (!rst_n) begin
            fill      <= '0;
            taken     <= '0;
            burst_seq <= '0;
            burst_beats <= '0;
            burst_last  <= 1'b0;
        end else begin
            if (!enable) taken <= '0;
            if (take) begin
                burst_data[fill[$clog2(BURST)-1:0]*W +: W] <= tdata;
                taken <= taken + 32'd1;
                if (close) begin
                    fill        <= '0;
                    burst_beats <= fill + 16'd1;
                    burst_last  <= tlast;
                    burst_seq   <= burst_seq + 32'd1;
                end else begin
                    fill <= fill + 16'd1;
                end
            end
        end
    end
endmodule
`default_nettype wire
