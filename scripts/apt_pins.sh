# Sourced by setup.sh and setup_bench.sh: apt-get whatever is missing, then check each pinned
# package's upstream version. Usage: apt_install_pinned PINS_ARRAY_NAME [unpinned packages...]
apt_install_pinned() {
  local -n pins=$1
  shift
  local tag pkg have missing=()
  tag=$(basename "$0" .sh)
  for pkg in "${!pins[@]}" "$@"; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q 'install ok installed' || missing+=("$pkg")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    echo "$tag: installing Debian packages: ${missing[*]}"
    local sudo_cmd=""
    [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
    $sudo_cmd apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null
  fi
  for pkg in "${!pins[@]}"; do
    have=$(dpkg-query -W -f='${Version}' "$pkg" 2>/dev/null || true)
    case "$have" in
      "${pins[$pkg]}"*|*:"${pins[$pkg]}"*) ;;
      *) echo "$tag: $pkg is '${have:-not installed}', but deformkit is pinned to ${pins[$pkg]}" \
              "(apt-cache policy $pkg shows what this machine's sources offer)" >&2
         return 1 ;;
    esac
  done
}
