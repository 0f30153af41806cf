namespace dfo::io {}
