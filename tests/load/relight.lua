-- relight.lua: the wrk script of tests/load/serve_load.sh. Every request is a relight of the
-- uploaded photo (the URL given to wrk) under the next of the seven presets; at the end one line of
-- figures that serve_load.sh reads.
local next_preset = 0

request = function()
    next_preset = (next_preset + 1) % 7
    return wrk.format("POST", nil, { ["Content-Type"] = "application/json" }, '{"preset":' .. next_preset .. '}')
end

done = function(summary, latency, requests)
    local e = summary.errors
    io.write(string.format("figures: requests %d seconds %.1f rps %.3f p50_ms %.0f p90_ms %.0f p99_ms %.0f max_ms %.0f "
        .. "non2xx %d socket_errors %d\n", summary.requests, summary.duration / 1e6,
        summary.requests / (summary.duration / 1e6), latency:percentile(50) / 1000, latency:percentile(90) / 1000,
        latency:percentile(99) / 1000, latency.max / 1000, e.status, e.connect + e.read + e.write + e.timeout))
end
