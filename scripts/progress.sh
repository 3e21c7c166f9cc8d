# Sourced by the build scripts. `quietly LABEL CMD...` runs a long command
# with its output in a log file and prints one line of progress every so
# many crates cargo compiles, then how long it took; on failure it prints
# the log's tail and exits with the command's status.
quietly() {
    local label=$1
    shift
    local log
    log=$(mktemp)
    local start
    start=$(date +%s)
    echo "== $label"
    local rc=0
    "$@" >"$log" 2>&1 &
    local pid=$!
    local shown=0
    while kill -0 "$pid" 2>/dev/null; do
        sleep 5
        local done_now
        done_now=$(grep -c "Compiling " "$log" || true)
        if [ "$done_now" -ge $((shown + 25)) ]; then
            echo "   ... $done_now crates compiled, $(($(date +%s) - start)) s"
            shown=$done_now
        fi
    done
    wait "$pid" || rc=$?
    if [ "$rc" != 0 ]; then
        tail -n 60 "$log"
        rm -f "$log"
        echo "!! $label failed (exit $rc)" >&2
        exit "$rc"
    fi
    rm -f "$log"
    echo "   done in $(($(date +%s) - start)) s"
}
