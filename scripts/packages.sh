# Sourced by the scripts: `ensure_packages NAME [APT-OPTION...] PACKAGE...` installs the
# Debian packages not yet installed (as root with apt-get, otherwise through sudo) and says
# which, under NAME. Arguments starting with `--` go to apt-get install.
ensure_packages() {
    local name=$1; shift
    local options=() missing=() p
    for p in "$@"; do
        if [[ $p == --* ]]; then
            options+=("$p")
        else
            dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
        fi
    done
    [ "${#missing[@]}" -eq 0 ] && return 0
    local as_root=()
    [ "$(id -u)" -eq 0 ] || as_root=(sudo)
    echo "$name: installing ${missing[*]}"
    "${as_root[@]}" apt-get update -qq
    DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -qq "${options[@]}" "${missing[@]}"
}
