#!/usr/bin/env bash
# hil-tests/run.sh: run commands against a real vcan interface, natively where the kernel has
# CAN, otherwise inside a Debian kernel booted by qemu (TCG) that mounts the host's root over
# 9p and chroots into it, so host binaries run unchanged. See hil-tests/README.md.
#
#   run.sh setup                       install/download/build what the current mode needs
#   run.sh mode                        print "native" or "qemu" (after setup)
#   run.sh exec [OPTS] -- CMD [ARG..]  run CMD (cwd kept) with vcan0 up; exit = CMD's status
#   run.sh script [OPTS] FILE [ARG..]  run a bash script the same way
#   run.sh suite [OPTS] [FILE..]       run scenario scripts in ONE guest boot (default: smoke
#                                      tests and hil-tests/scenarios/*.sh); "N passed, N failed"
#   run.sh smoke [OPTS]                run only the smoke tests (vcan, cansend/candump, cansmoke)
# OPTS: --timeout SECONDS (whole run; qemu is killed then), --no-build, --iface NAME
#
# Exit codes: the command's status; 124 timed out; 125 the runner or guest failed before or
# around the command (message says which); 2 usage.
set -euo pipefail

HIL_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO="$(dirname "$HIL_DIR")"
CACHE="$(realpath -m "${HIL_CACHE:-$HIL_DIR/.cache}")"   # absolute: the guest sees the same paths
MODE_WANTED="${HIL_MODE:-auto}"          # auto | native | qemu
GUEST_MEM="${HIL_GUEST_MEM:-2G}"
GUEST_CPUS="${HIL_GUEST_CPUS:-2}"
TARGET_DIR="${CARGO_TARGET_DIR:-$REPO/target}"
PROFILE="${HIL_PROFILE:-release}"

say() { echo "HIL: $*" >&2; }
die() { echo "HIL: error: $*" >&2; exit 125; }
usage() { sed -n '2,18p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2; }
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }

# ---------------------------------------------------------------------------------------------
# Host packages

have_pkg() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q 'install ok installed'; }

apt_updated=0
apt_update_once() {
    if [[ $apt_updated == 0 ]]; then
        say "apt-get update"
        apt-get update -q -o DPkg::Lock::Timeout=600 >/dev/null || die "apt-get update failed"
        apt_updated=1
    fi
}

# ensure_packages PKG...: install the Debian packages that are missing (one apt call).
ensure_packages() {
    local missing=() p
    for p in "$@"; do have_pkg "$p" || missing+=("$p"); done
    [[ ${#missing[@]} == 0 ]] && return 0
    if [[ $(id -u) != 0 ]]; then
        die "missing packages: ${missing[*]}; run as root or: sudo apt-get install ${missing[*]}"
    fi
    command -v apt-get >/dev/null || die "missing ${missing[*]} and no apt-get (not Debian?)"
    apt_update_once
    say "installing ${missing[*]}"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends -o DPkg::Lock::Timeout=600 "${missing[@]}" \
        >"$CACHE/apt-install.log" 2>&1 \
        || { tail -20 "$CACHE/apt-install.log" >&2; die "apt-get install ${missing[*]} failed"; }
}

# ---------------------------------------------------------------------------------------------
# Guest kernel and initramfs (cached under $CACHE)

KDIR="$CACHE/kernel"      # vmlinuz, modules/*.ko, VERSION, PACKAGE

# The exact name of the kernel package linux-image-amd64 depends on (never a glob: that would
# fetch every flavour).
kernel_package_name() {
    local name
    name=$(apt-cache depends linux-image-amd64 2>/dev/null \
        | awk '$1 == "Depends:" && $2 ~ /^linux-image-[0-9][0-9.]*-[0-9]+-amd64$/ { print $2; exit }')
    if [[ -z "$name" ]]; then
        apt_update_once
        name=$(apt-cache depends linux-image-amd64 2>/dev/null \
            | awk '$1 == "Depends:" && $2 ~ /^linux-image-[0-9][0-9.]*-[0-9]+-amd64$/ { print $2; exit }')
    fi
    [[ -n "$name" ]] || die "apt-cache depends linux-image-amd64 names no linux-image-*-amd64 package"
    echo "$name"
}

# cached_deb PKG: the cached .deb of PKG (exact name), if any.
cached_deb() { ls "$CACHE/debs/${1}_"*.deb 2>/dev/null | head -1 || true; }

# fetch_deb PKG: prints the path of PKG's .deb, downloading it into $CACHE/debs if needed.
# A failed download is retried once after apt-get update (stale package lists name versions
# the mirror no longer has). Dies on failure.
fetch_deb() {
    local p="$1" deb
    mkdir -p "$CACHE/debs"
    deb=$(cached_deb "$p")
    if [[ -z "$deb" ]]; then
        say "downloading $p"
        if ! (cd "$CACHE/debs" && apt-get download -q "$p" >/dev/null 2>"$CACHE/apt-download.log"); then
            [[ $apt_updated == 0 ]] || { cat "$CACHE/apt-download.log" >&2; die "apt-get download $p failed"; }
            apt_update_once
            (cd "$CACHE/debs" && apt-get download -q "$p" >/dev/null 2>"$CACHE/apt-download.log") \
                || { cat "$CACHE/apt-download.log" >&2; die "apt-get download $p failed"; }
        fi
        deb=$(cached_deb "$p")
        [[ -n "$deb" ]] || die "apt-get download $p left no .deb in $CACHE/debs"
    fi
    FETCHED_DEB="$deb"
}

ensure_kernel() {
    [[ -f "$KDIR/READY" ]] && return 0
    local pkg deb tmp
    pkg=$(kernel_package_name)
    if [[ -z "$(cached_deb "$pkg")" && $apt_updated == 0 ]]; then
        # The name comes from the package lists: make sure they are current before fetching.
        apt_update_once
        pkg=$(kernel_package_name)
    fi
    fetch_deb "$pkg"
    deb="$FETCHED_DEB"
    say "unpacking vmlinuz and modules from $(basename "$deb")"
    tmp="$KDIR.tmp"
    rm -rf "$tmp" && mkdir -p "$tmp/x" "$tmp/modules"
    local patterns=('./boot/vmlinuz-*') m
    while read -r m; do
        case "$m" in ''|'#'*) continue ;; esac
        patterns+=("./lib/modules/*/kernel/$m.ko")
    done <"$HIL_DIR/guest/modules.list"
    dpkg-deb --fsys-tarfile "$deb" | tar -x -C "$tmp/x" --wildcards "${patterns[@]}" \
        || die "extracting from $deb failed (a module of guest/modules.list missing?)"
    local vmlinuz
    vmlinuz=$(ls "$tmp"/x/boot/vmlinuz-* | head -1)
    basename "$vmlinuz" | sed 's/^vmlinuz-//' >"$tmp/VERSION"
    echo "$pkg" >"$tmp/PACKAGE"
    mv "$vmlinuz" "$tmp/vmlinuz"
    find "$tmp/x/lib/modules" -name '*.ko' -exec mv {} "$tmp/modules/" \;
    rm -rf "$tmp/x"
    touch "$tmp/READY"
    rm -rf "$KDIR" && mv "$tmp" "$KDIR"
}

# unpack_debs DIR PKG...: apt-get download the named packages (exact names) into
# $CACHE/debs unless a .deb of each is already there, then unpack them all into DIR.
# Used for packages that must not be installed on the host: busybox-static would replace the
# machine's busybox, and qemu-system-x86 7.2 would remove the machine's newer qemu-utils.
unpack_debs() {
    local dir="$1" p deb debs=()
    shift
    for p in "$@"; do
        [[ -n "$(cached_deb "$p")" ]] || apt-cache show "$p" >/dev/null 2>&1 || apt_update_once
        fetch_deb "$p"
        debs+=("$FETCHED_DEB")
    done
    rm -rf "$dir.tmp" && mkdir -p "$dir.tmp"
    for deb in "${debs[@]}"; do
        dpkg-deb -x "$deb" "$dir.tmp" || die "unpacking $deb failed"
        basename "$deb" >>"$dir.tmp/DEBS"
    done
    rm -rf "$dir" && mv "$dir.tmp" "$dir"
}

BUSYBOX="$CACHE/busybox/bin/busybox"
ensure_busybox() {
    [[ -x "$BUSYBOX" ]] || unpack_debs "$CACHE/busybox" busybox-static
    file_is_static "$BUSYBOX" || die "$BUSYBOX is not a static binary"
}

# qemu: the host's qemu-system-x86_64 if it has one (or $HIL_QEMU), else Debian's unpacked
# under $CACHE/qemu, its shared libraries installed with apt (libraries only: no conflicts).
QEMU=""
QEMU_DIRS=()
ensure_qemu() {
    if [[ -n "${HIL_QEMU:-}" ]]; then
        QEMU="$HIL_QEMU"
        return 0
    fi
    if command -v qemu-system-x86_64 >/dev/null; then
        QEMU=$(command -v qemu-system-x86_64)
        return 0
    fi
    local qdir="$CACHE/qemu"
    if [[ ! -f "$qdir/DEBS" ]]; then
        local libs
        apt-cache show qemu-system-x86 >/dev/null 2>&1 || apt_update_once
        # The qemu packages' own dependencies that are shared libraries (never qemu-*).
        libs=$(apt-cache depends --no-recommends --no-suggests --no-conflicts --no-breaks \
                --no-replaces --no-enhances qemu-system-x86 qemu-system-common \
            | awk '$1 == "Depends:" && $2 ~ /^lib|^zlib/ { print $2 }' | sort -u)
        [[ -n "$libs" ]] || die "apt-cache depends qemu-system-x86 listed no libraries"
        # shellcheck disable=SC2086
        ensure_packages $libs
        unpack_debs "$qdir" qemu-system-x86 qemu-system-common qemu-system-data seabios
    fi
    QEMU="$qdir/usr/bin/qemu-system-x86_64"
    # Debian's qemu loads TCG itself as a module (accel-tcg-x86_64.so) from its module dir.
    export QEMU_MODULE_DIR="$qdir/usr/lib/x86_64-linux-gnu/qemu"
    QEMU_DIRS=(-L "$qdir/usr/share/qemu" -L "$qdir/usr/share/seabios")
    if ldd "$QEMU" "$QEMU_MODULE_DIR/accel-tcg-x86_64.so" 2>/dev/null | grep -q 'not found'; then
        ldd "$QEMU" "$QEMU_MODULE_DIR/accel-tcg-x86_64.so" | grep 'not found' >&2
        die "the unpacked qemu misses shared libraries (listed above)"
    fi
}

# The kernel qemu boots: vmlinux, the ELF inside Debian's xz-compressed bzImage, which qemu
# starts directly through its PVH entry (CONFIG_PVH=y); under TCG this skips seconds of BIOS
# and decompression per boot (wall time to "ready" about 2 s shorter at low load, up to 10 s
# at high load). Falls back to the bzImage if the ELF cannot be extracted.
KIMAGE=""
ensure_vmlinux() {
    KIMAGE="$KDIR/vmlinuz"
    if [[ ! -f "$KDIR/vmlinux" && ! -f "$KDIR/vmlinux.failed" ]]; then
        local off
        off=$(LC_ALL=C grep -obUaP '\xfd7zXZ\x00' "$KDIR/vmlinuz" 2>/dev/null | head -1 | cut -d: -f1 || true)
        # xz stops with an error at the data that follows the stream: judge by the result.
        if [[ -n "$off" ]] && command -v xz >/dev/null; then
            tail -c +"$((off + 1))" "$KDIR/vmlinuz" | xz -dc >"$KDIR/vmlinux.tmp" 2>/dev/null || true
        fi
        if [[ -f "$KDIR/vmlinux.tmp" && "$(head -c 4 "$KDIR/vmlinux.tmp" | od -An -c | tr -d ' ')" == '177ELF' ]]; then
            mv "$KDIR/vmlinux.tmp" "$KDIR/vmlinux"
        else
            rm -f "$KDIR/vmlinux.tmp"
            touch "$KDIR/vmlinux.failed"
            say "could not extract vmlinux from the bzImage; booting the bzImage (slower)"
        fi
    fi
    [[ -f "$KDIR/vmlinux" ]] && KIMAGE="$KDIR/vmlinux"
    return 0
}

INITRD="$CACHE/initramfs.cpio.gz"

# The initramfs depends on busybox, the module set and guest/init: rebuilt when any changes.
initramfs_key() {
    cat "$HIL_DIR/guest/init" "$HIL_DIR/guest/modules.list" "$KDIR/VERSION"
    cat "$CACHE/busybox/DEBS"
}

ensure_initramfs() {
    local key
    key=$(initramfs_key | sha256sum | cut -d' ' -f1)
    if [[ -f "$INITRD" && -f "$INITRD.key" && "$(cat "$INITRD.key")" == "$key" ]]; then
        return 0
    fi
    say "building the initramfs"
    local root="$CACHE/initramfs.tmp" m
    rm -rf "$root" && mkdir -p "$root"/{bin,dev,proc,sys,mnt,modules}
    cp "$BUSYBOX" "$root/bin/busybox"
    cp "$HIL_DIR/guest/init" "$root/init" && chmod 755 "$root/init"
    cp "$HIL_DIR/guest/modules.list" "$root/modules.list"
    while read -r m; do
        case "$m" in ''|'#'*) continue ;; esac
        [[ -f "$KDIR/modules/${m##*/}.ko" ]] || die "module ${m##*/}.ko missing from $KDIR/modules"
        cp "$KDIR/modules/${m##*/}.ko" "$root/modules/"
    done <"$HIL_DIR/guest/modules.list"
    (cd "$root" && find . | cpio -o -H newc --quiet | gzip -1 >"$INITRD.tmp") \
        || die "building the initramfs failed"
    mv -f "$INITRD.tmp" "$INITRD"
    echo "$key" >"$INITRD.key"
    rm -rf "$root"
}

# No 'file' dependency: a static binary has no PT_INTERP, so ldd says so.
file_is_static() { ! ldd "$1" >/dev/null 2>&1; }

# ---------------------------------------------------------------------------------------------
# Mode

IFACE="${HIL_IFACE:-vcan0}"
MODE=""
decide_mode() {
    [[ -n "$MODE" ]] && return 0
    case "$MODE_WANTED" in
        qemu) MODE=qemu ;;
        native)
            "$REPO/vcan-setup.sh" "$IFACE" >&2 || die "HIL_MODE=native but $IFACE cannot be set up"
            MODE=native ;;
        auto)
            local rc=0
            "$REPO/vcan-setup.sh" "$IFACE" >/dev/null 2>"$CACHE/vcan-setup.log" || rc=$?
            case $rc in
                0) MODE=native ;;
                2) MODE=qemu
                   say "the host kernel has no CAN: $(head -1 "$CACHE/vcan-setup.log" | sed 's/^vcan-setup: //'); using the emulated Debian kernel" ;;
                *) cat "$CACHE/vcan-setup.log" >&2; die "vcan-setup.sh failed (exit $rc)" ;;
            esac ;;
        *) die "HIL_MODE must be auto, native or qemu (got '$MODE_WANTED')" ;;
    esac
}

setup() {
    mkdir -p "$CACHE"
    # One setup at a time per cache (several engineers, or CI, may start the runner at once).
    exec 9>"$CACHE/setup.lock"
    flock 9 || die "cannot lock $CACHE/setup.lock"
    decide_mode
    local t0
    t0=$(now)
    if [[ $MODE == native ]]; then
        ensure_packages can-utils
    else
        ensure_packages cpio can-utils iproute2 xz-utils
        ensure_qemu
        ensure_busybox
        ensure_kernel
        ensure_vmlinux
        ensure_initramfs
    fi
    local took
    took=$(elapsed "$t0")
    [[ "$took" == 0.* ]] || say "setup ($MODE) took ${took} s"
    exec 9>&-
}

# ---------------------------------------------------------------------------------------------
# Build

NO_BUILD="${HIL_NO_BUILD:-0}"
build() {   # build PACKAGE...
    [[ "$NO_BUILD" == 1 ]] && return 0
    local args=() p
    for p in "$@"; do args+=(-p "$p"); done
    local prof=()
    [[ "$PROFILE" == release ]] && prof=(--release)
    say "cargo build ${prof[*]} ${args[*]} --bins"
    (cd "$REPO" && cargo build -q "${prof[@]}" "${args[@]}" --bins) || die "cargo build failed"
}

# ---------------------------------------------------------------------------------------------
# Jobs

# Variables carried from the caller into the job (the guest starts with the kernel's bare
# environment). HIL_* and RUST_* are carried as a whole.
PASS_VARS=(PATH HOME USER LANG LC_ALL TERM CI CARGO_TARGET_DIR CARGO_HOME RUSTUP_HOME)

# new_job CMD...: create a job directory holding cmd, env and start; prints its path.
new_job() {
    mkdir -p "$CACHE/jobs"
    local dir v
    dir=$(mktemp -d "$CACHE/jobs/job.XXXXXX")
    [[ "$dir" =~ ^[A-Za-z0-9_./+-]+$ ]] \
        || die "the job path '$dir' has characters that cannot go on a kernel command line; set HIL_CACHE"
    {
        printf 'exec'
        printf ' %q' "$@"
        printf '\n'
    } >"$dir/cmd"
    {
        for v in "${PASS_VARS[@]}"; do
            [[ -n "${!v+x}" ]] && printf 'export %s=%q\n' "$v" "${!v}"
        done
        while read -r v; do
            printf 'export %s=%q\n' "$v" "${!v}"
        done < <(compgen -e | grep -E '^(HIL_|RUST_)' | grep -vxE 'HIL_(MODE|RUNNING_IN|IFACE|REPO|CWD|BIN|JOB|QEMU|ACCEL|QEMU_ARGS|KERNEL_ARGS|CACHE|9P_OPTS)' || true)
        printf 'export HIL_RUNNING_IN=%q HIL_IFACE=%q HIL_REPO=%q HIL_CWD=%q HIL_JOB=%q\n' \
            "$MODE" "$IFACE" "$REPO" "$PWD" "$dir"
        printf 'export HIL_BIN=%q HIL_OUT_ROOT=%q\n' "$TARGET_DIR/$PROFILE" "${HIL_OUT_ROOT:-$CACHE/out}"
    } >"$dir/env"
    printf 'exec /bin/bash %q %q\n' "$HIL_DIR/guest/job.sh" "$dir" >"$dir/start"
    echo "$dir"
}

# run_job DIR TIMEOUT: run the job natively or in the guest; returns its exit status.
run_job() {
    local dir="$1" limit="$2" rc=0 t0
    t0=$(now)
    if [[ $MODE == native ]]; then
        # timeout puts the job in a process group of its own (so that the job's children are
        # killed with it), out of reach of the terminal's Ctrl-C: forward INT/TERM by hand.
        timeout -k 5 "$limit" bash "$dir/start" &
        local tpid=$!
        trap 'kill -TERM $tpid 2>/dev/null; wait $tpid; exit 130' INT TERM
        wait $tpid || rc=$?
        trap - INT TERM
    else
        local share_opts=security_model=passthrough
        [[ $(id -u) == 0 ]] || share_opts=security_model=none
        say "booting $(cat "$KDIR/PACKAGE") under qemu (TCG, ${GUEST_CPUS} vCPUs, ${GUEST_MEM}), limit ${limit} s"
        set +e
        # --foreground: qemu stays in our process group, so Ctrl-C reaches it.
        timeout --foreground -k 5 "$limit" "$QEMU" "${QEMU_DIRS[@]}" \
            -accel "${HIL_ACCEL:-tcg,thread=multi}" -cpu max -m "$GUEST_MEM" -smp "$GUEST_CPUS" \
            -nodefaults -no-user-config -display none -no-reboot \
            -chardev stdio,id=con,signal=off -serial chardev:con \
            -kernel "$KIMAGE" -initrd "$INITRD" \
            -append "console=ttyS0 quiet loglevel=3 panic=-1 tsc=reliable hil9p=${HIL_9P_OPTS-cache=loose} ${HIL_KERNEL_ARGS:-} hiljob=$dir" \
            -fsdev "local,id=hostroot,path=/,$share_opts,multidevs=remap" \
            -device virtio-9p-pci,fsdev=hostroot,mount_tag=hostroot \
            ${HIL_QEMU_ARGS:-} \
            </dev/null | grep -v --line-buffered -E '^\[ *[0-9.]+\] reboot: '
        rc=${PIPESTATUS[0]}
        set -e
        # qemu exits 0 when the guest reboots (-no-reboot); the job's status is in its file.
        [[ $rc == 0 ]] && rc=""
    fi
    if [[ ${rc:-0} == 124 || ${rc:-0} == 137 ]]; then
        say "TIMEOUT: the job did not finish within ${limit} s; $([[ $MODE == qemu ]] && echo qemu || echo it) was killed"
        return 124
    fi
    if [[ -f "$dir/status" ]]; then
        rc=$(cat "$dir/status")
    elif [[ $MODE == qemu ]]; then
        say "the guest stopped without reporting an exit status (qemu exit ${rc:-0}; see HIL-INIT lines above)"
        return 125
    fi
    say "$MODE job finished with status $rc after $(elapsed "$t0") s"
    return "$rc"
}

# ---------------------------------------------------------------------------------------------
# Commands

TIMEOUT="${HIL_TIMEOUT:-}"
parse_opts() {   # sets OPT_REST to the remaining arguments
    OPT_REST=()
    while [[ $# -gt 0 ]]; do
        case "$1" in
            --timeout) [[ $# -ge 2 && "$2" =~ ^[0-9]+$ ]] || usage; TIMEOUT="$2"; shift 2 ;;
            --timeout=*) TIMEOUT="${1#*=}"; [[ "$TIMEOUT" =~ ^[0-9]+$ ]] || usage; shift ;;
            --no-build) NO_BUILD=1; shift ;;
            --iface) [[ $# -ge 2 ]] || usage; IFACE="$2"; shift 2 ;;
            --) shift; OPT_REST=("$@"); return 0 ;;
            -*) echo "HIL: unknown option $1" >&2; usage ;;
            *) OPT_REST=("$@"); return 0 ;;
        esac
    done
}

run_cmd() {   # run_cmd DEFAULT_TIMEOUT BUILD_PACKAGES CMD...
    local def_timeout="$1" pkgs="$2"
    shift 2
    setup
    # shellcheck disable=SC2086
    build ${HIL_CARGO_PACKAGES:-$pkgs}
    local dir rc=0
    dir=$(new_job "$@")
    run_job "$dir" "${TIMEOUT:-$def_timeout}" || rc=$?
    # The suite's "N passed, N failed" goes last, where CI looks for it.
    [[ -f "$dir/summary" ]] && cat "$dir/summary"
    [[ "${HIL_KEEP_JOBS:-0}" == 1 ]] || rm -rf "$dir"
    return "$rc"
}

cmd="${1:-}"
[[ $# -gt 0 ]] && shift
case "$cmd" in
    setup) parse_opts "$@"; setup; say "ready: mode $MODE" ;;
    mode) mkdir -p "$CACHE"; decide_mode; echo "$MODE" ;;
    exec)
        parse_opts "$@"
        [[ ${#OPT_REST[@]} -gt 0 ]] || usage
        run_cmd 600 cnc402-hil "${OPT_REST[@]}" ;;
    script)
        parse_opts "$@"
        [[ ${#OPT_REST[@]} -gt 0 ]] || usage
        [[ -f "${OPT_REST[0]}" ]] || die "no such script: ${OPT_REST[0]}"
        run_cmd 600 cnc402-hil bash "${OPT_REST[@]}" ;;
    suite)
        parse_opts "$@"
        run_cmd 1200 "cnc402 cnc402-hil" bash "$HIL_DIR/guest/suite.sh" "${OPT_REST[@]}" ;;
    smoke)
        parse_opts "$@"
        if [[ $(HIL_MODE="$MODE_WANTED" "$0" mode 2>/dev/null) == qemu ]]; then
            # The host's own figures, as the peer of the guest's (same run, same load).
            setup && build cnc402-hil
            say "host peer (no CAN here): $("$TARGET_DIR/$PROFILE/cansmoke" --latency-only --cycles 2000 2>&1 | grep -E 'wake-up|mlockall' | sed 's/^cansmoke: //' | tr '\n' ' ')"
            NO_BUILD=1
        fi
        run_cmd 600 cnc402-hil bash "$HIL_DIR/guest/suite.sh" "$HIL_DIR"/smoke/*.sh ;;
    ''|-h|--help|help) usage ;;
    *) echo "HIL: unknown command '$cmd'" >&2; usage ;;
esac
