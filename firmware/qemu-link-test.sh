#!/usr/bin/env bash
# The controller's serial link under QEMU, against `armcal stream`.
#
#   firmware/qemu-link-test.sh [ELF]
#
# ELF is the production build (without it, built here); the `bench` build works
# too (its boot benchmark's spans are not the link's and are left out). The
# boot benchmark's instructions are checked by budgets.sh.
#
# 1. armcal identifies the FIGAROH UR10e (built-in model and data) and writes
#    its calibration for targets in the robot's base frame (the set's base is
#    the camera's world frame); a copy with one payload byte flipped is the
#    corrupt one. A simulated tracker session of a UR10e (120 positions) gives
#    a position-only calibration.
# 2. The joint commands: 200 ticks of a smooth motion (0.3 rad sine waves)
#    around the data set's first pose. (Its 23 poses in a row are no servo
#    stream: far apart, most corrections hit the change-per-tick bound and some
#    do not converge, and an unconverged correction is the best point of a
#    search that f32 and f64 arithmetic end differently, so the two sides'
#    commands then differ by millimetres for the ticks after it.)
# 3. QEMU (netduinoplus2, -icount shift=3) boots the firmware with USART1 on a
#    TCP socket on 127.0.0.1 and the instruction-counting plugin
#    (qemu-insn-count.c, built here with cc) on bench_start/bench_end, which
#    the firmware calls around each command's correction.
# 4. `armcal stream` with the corrupt calibration must exit 2 and say why (CRC);
#    then with the good one it streams every row, writes the corrected commands
#    and halts the firmware, which must exit with success.
# 5. Both the controller's f32 commands and `armcal compensate --servo`'s f64
#    ones are evaluated with the calibrated model (`armcal predict`): every
#    tool point must agree within 2 um; then the same with the position-only
#    calibration, streamed to a second boot.
# 6. The same stream over a serial port (`armcal stream --serial`): QEMU boots
#    the firmware again with USART1 on a pseudo-terminal, a tty like a USB
#    serial adapter's (its baud rate is accepted and ignored); the corrected
#    commands must be the same bytes as over TCP.
# 7. Prints the instructions per correction of the link's commands, the
#    controller's summary (deadline misses, stack high-water mark) and the
#    firmware's size.
#
# Timing under QEMU is not real: with -icount shift=3 every instruction counts
# 8 ns, so the firmware's SysTick measures instructions x 1.344 cycles.
# KEEP_WORK=1 keeps the files it writes (calibrations, commands, logs).
# Bounded: QEMU runs under `timeout` (QEMU_TIMEOUT, default 150 s), every
# armcal call under its own. Exit code 0 when every check passed.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")
if [[ $# -ge 1 ]]; then
    elf=$(realpath "$1")
else
    (cd "$here" && cargo build --release)
    elf="${CARGO_TARGET_DIR:-$here/target}/thumbv7em-none-eabihf/release/armcal-firmware"
fi
[[ -f $elf ]] || { echo "qemu-link-test.sh: no firmware ELF at $elf" >&2; exit 2; }
armcal=${ARMCAL:-}
if [[ -z $armcal ]]; then
    (cd "$root" && cargo build -p armcal)
    armcal="${CARGO_TARGET_DIR:-$root/target}/debug/armcal"
fi
tools="$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin"
timeout_s=${QEMU_TIMEOUT:-150}

work=$(mktemp -d)
qemu_pid=
cleanup() {
    [[ -n $qemu_pid ]] && kill "$qemu_pid" 2>/dev/null
    if [[ -n ${KEEP_WORK:-} ]]; then echo "work files kept in $work"; else rm -rf "$work"; fi
}
trap cleanup EXIT
fail() {
    echo "qemu-link-test.sh: FAILED: $*" >&2
    exit 1
}
run() { timeout 60 "$armcal" "$@"; }

echo "== calibration and commands"
# The camera's world frame is the set's base: the controller's targets are in
# the robot's own base frame, so the calibration leaves the base out.
run identify --model figaroh-ur10e-camera --data figaroh-ur10e-camera --targets base \
    --out "$work/ur10e.cal" >/dev/null
# A position-only calibration of a simulated UR10e (laser tracker, 120 points).
run simulate --model ur10e --poses 120 --seed 3 --out "$work/positions.csv" >/dev/null
run identify --model ur10e --data "$work/positions.csv" --out "$work/positions.cal" >/dev/null
cp "$work/ur10e.cal" "$work/corrupt.cal"
printf '\x5a' | dd of="$work/corrupt.cal" bs=1 seek=100 conv=notrunc status=none
data="$root/data/figaroh-ur10e-camera/measurements.csv"
awk -F, '
    /^#/ || /^q1/ { next }
    !n++ { for (j = 1; j <= 6; j++) q0[j] = $j }
    END {
        print "q1,q2,q3,q4,q5,q6"
        for (t = 0; t < 200; t++) {
            line = ""
            for (j = 1; j <= 6; j++)
                line = line (j > 1 ? "," : "") sprintf("%.9f", q0[j] + 0.3 * sin(6.283185307179586 * t / 200 + j))
            print line
        }
    }' "$data" >"$work/joints.csv"
rows=$(($(wc -l <"$work/joints.csv") - 1))
echo "$rows rows of joint commands"

echo "== QEMU"
cc -shared -fPIC -O2 -Wall -o "$work/insn-count.so" "$here/qemu-insn-count.c"
symbol() {
    "$tools/llvm-nm" -C "$elf" | awk -v name="armcal_firmware::$1::" 'index($0, " " name) && !found++ { print "0x" $1 }'
}
start=$(symbol bench_start)
end=$(symbol bench_end)
[[ -n $start && -n $end ]] || fail "no bench_start/bench_end symbols in $elf"
# Boots the firmware under QEMU with USART1 on a TCP socket of this process's
# own on 127.0.0.1 (the next port if one is taken), counting instructions into
# $work/insn-count$1.log; sets port and qemu_pid.
boot_tcp() {
    local listening= try
    for try in 0 1 2 3 4; do
        port=$((20000 + ($$ + 977 * try + 131 * ${1:-0}) % 20000))
        timeout "$timeout_s" qemu-system-arm -cpu cortex-m4 -machine netduinoplus2 \
            -display none -monitor none -icount shift=3 \
            -serial "tcp:127.0.0.1:$port,server=on,wait=on" \
            -semihosting-config enable=on,target=native \
            -plugin "$work/insn-count.so,start=$start,end=$end" -d plugin -D "$work/insn-count$1.log" \
            -kernel "$elf" >"$work/defmt$1.raw" 2>"$work/qemu$1.err" &
        qemu_pid=$!
        for _ in $(seq 100); do
            grep -q "waiting for connection" "$work/qemu$1.err" 2>/dev/null && { listening=1; break; }
            kill -0 "$qemu_pid" 2>/dev/null || break
            sleep 0.1
        done
        [[ -n $listening ]] && break
        kill "$qemu_pid" 2>/dev/null || true
        wait "$qemu_pid" 2>/dev/null || true
        qemu_pid=
        cat "$work/qemu$1.err" >&2
    done
    [[ -n $listening ]] || fail "QEMU did not start"
}
boot_tcp ""
echo "QEMU listening on 127.0.0.1:$port"

echo "== a corrupt calibration is refused with its reason"
set +e
run stream --calibration "$work/corrupt.cal" --joints "$work/joints.csv" \
    --tcp "127.0.0.1:$port" --out "$work/never.csv" 2>"$work/corrupt.err"
rc=$?
set -e
cat "$work/corrupt.err"
[[ $rc -eq 2 ]] || fail "armcal stream with a corrupt calibration exited $rc, not 2"
grep -q "the controller refused the calibration: damaged: the CRC does not match" "$work/corrupt.err" ||
    fail "the refusal does not give the CRC as the reason"
[[ ! -e $work/never.csv ]] || fail "a refused stream wrote its output"

echo "== the good calibration, every row, then halt"
run stream --calibration "$work/ur10e.cal" --joints "$work/joints.csv" \
    --tcp "127.0.0.1:$port" --out "$work/controller.csv" --halt 2>"$work/stream.err" ||
    { cat "$work/stream.err" >&2; fail "armcal stream failed"; }
grep -v "warning:" "$work/stream.err" || true
# Row warnings name the file and line (`j.csv:17: …`); the others are the
# quantities outside the calibration's identified ranges.
row_warnings() { grep -cE 'warning: [^ ]*:[0-9]+: ' "$1" || true; }
grep -E 'warning: [^ ]*: ' "$work/stream.err" | grep -vE 'warning: [^ ]*:[0-9]+: ' || true
echo "($(row_warnings "$work/stream.err") rows reported bounded or not converged, as armcal compensate reports them)"
set +e
wait "$qemu_pid"
rc=$?
set -e
qemu_pid=
if command -v defmt-print >/dev/null; then
    defmt-print -e "$elf" <"$work/defmt.raw" || true
fi
[[ $rc -eq 0 ]] || fail "the firmware exited with $rc"
echo "firmware exited with success"

echo "== the same stream over a serial port (a pseudo-terminal)"
if [[ ! -c /dev/ptmx ]]; then
    echo "skipped: this machine has no pseudo-terminals (/dev/ptmx)"
else
    timeout "$timeout_s" qemu-system-arm -cpu cortex-m4 -machine netduinoplus2 \
        -display none -monitor none -icount shift=3 -serial pty \
        -semihosting-config enable=on,target=native \
        -kernel "$elf" >"$work/pty.out" 2>"$work/pty.err" &
    qemu_pid=$!
    pty=
    for _ in $(seq 100); do
        # QEMU names the terminal on its standard output, among the defmt frames.
        pty=$(grep -aho '/dev/pts/[0-9]*' "$work/pty.out" "$work/pty.err" 2>/dev/null | head -n 1 || true)
        [[ -n $pty ]] && break
        sleep 0.1
    done
    [[ -n $pty ]] || fail "QEMU named no pseudo-terminal"
    # The USART drops what arrives before the firmware turns it on (well under
    # a second after boot): wait, and try once more if the first frame was
    # lost.
    sleep 2
    streamed=
    for try in 1 2; do
        if run stream --calibration "$work/ur10e.cal" --joints "$work/joints.csv" \
            --serial "$pty" --out "$work/serial.csv" --halt 2>"$work/serial.err"; then
            streamed=1
            break
        fi
        sleep 3
    done
    [[ -n $streamed ]] || { cat "$work/serial.err" >&2; fail "armcal stream --serial $pty failed"; }
    tail -n 1 "$work/serial.err"
    set +e
    wait "$qemu_pid"
    rc=$?
    set -e
    qemu_pid=
    [[ $rc -eq 0 ]] || fail "the firmware behind the serial port exited with $rc"
    cmp <(grep -v '^#' "$work/serial.csv") <(grep -v '^#' "$work/controller.csv") ||
        fail "the commands over the serial port differ from those over TCP"
    echo "$rows rows over $pty: the same commands as over TCP"
fi

# Where the controller's f32 commands ($2) and `armcal compensate --servo`'s
# f64 ones put the tool point of the calibration $1: within 2 um everywhere.
agree() {
    run compensate --servo --calibration "$1" --joints "$work/joints.csv" --out "$work/host.csv" 2>/dev/null
    run predict --calibration "$1" --joints "$2" --out "$work/controller-pose.csv" 2>/dev/null
    run predict --calibration "$1" --joints "$work/host.csv" --out "$work/host-pose.csv" 2>/dev/null
    # The model's length unit is m: 2 um = 2e-6.
    paste -d, <(grep -v '^#' "$work/controller-pose.csv") <(grep -v '^#' "$work/host-pose.csv") | awk -F, -v rows="$rows" '
        NR == 1 { half = NF / 2; next }
        {
            d = sqrt(($1 - $(half + 1))^2 + ($2 - $(half + 2))^2 + ($3 - $(half + 3))^2)
            if (d > worst) { worst = d; at = NR - 1 }
            n++
        }
        END {
            printf "%d rows, worst tool-point difference %.3g m (row %d), bound 2e-6 m\n", n, worst, at
            if (n != rows || worst > 2e-6) exit 1
        }'
}

echo "== the controller's f32 commands against armcal compensate --servo's f64 ones, at the tool point (full pose)"
agree "$work/ur10e.cal" "$work/controller.csv" || fail "the controller's commands disagree with armcal compensate's"

echo "== a position-only calibration: the controller against armcal compensate --servo"
boot_tcp 2
run stream --calibration "$work/positions.cal" --joints "$work/joints.csv" \
    --tcp "127.0.0.1:$port" --out "$work/controller-positions.csv" --halt 2>"$work/stream-positions.err" ||
    { cat "$work/stream-positions.err" >&2; fail "armcal stream with the position-only calibration failed"; }
echo "($(row_warnings "$work/stream-positions.err") rows reported bounded or not converged)"
set +e
wait "$qemu_pid"
rc=$?
set -e
qemu_pid=
[[ $rc -eq 0 ]] || fail "the firmware exited with $rc after the position-only stream"
agree "$work/positions.cal" "$work/controller-positions.csv" ||
    fail "the controller's commands disagree with armcal compensate's (position-only calibration)"

echo "== instructions per correction of the link's commands (bench_start .. bench_end)"
grep "insn-count: span" "$work/insn-count.log" >"$work/spans" || fail "no instruction counts"
# One span per command streamed, the last ones (a bench build's boot benchmark
# comes before them).
tail -n "$rows" "$work/spans" | awk -v rows="$rows" '
    { c = $NF; n++; sum += c; if (c > max) max = c; v[n] = c }
    END {
        if (n != rows) { printf "%d spans for %d commands\n", n, rows; exit 1 }
        for (i = 2; i <= n; i++) { x = v[i]; for (j = i - 1; j >= 1 && v[j] > x; j--) v[j + 1] = v[j]; v[j + 1] = x }
        printf "link (the FIGAROH calibration, targets in the base frame, 0.3 rad sine waves): %d corrections, median %d, mean %d, max %d instructions\n", n, v[int((n + 1) / 2)], sum / n, max
    }' || fail "fewer instruction counts than commands"

echo "== size"
"$tools/llvm-size" -A "$elf" | grep -E '^(section|\.vector_table|\.text|\.rodata|\.data|\.bss) '
echo "qemu-link-test.sh: all checks passed"
