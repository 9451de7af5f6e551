"""The PGS kernel as Vitis HLS C++ (C simulation, Vitis HLS export script, resource estimates); see README.md."""
