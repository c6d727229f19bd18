# Sourced by make_captured.sh and make_people.sh: `fetch_bvh FILE URL MD5` downloads URL to FILE
# unless FILE is there, then checks its MD5 (a different file stops the script).
fetch_bvh() {
  local bvh=$1 url=$2 md5=$3 got
  if [ ! -f "$bvh" ]; then
    echo "downloading $(basename "$bvh") from $url"
    curl -fsSL "$url" -o "$bvh.part" && mv "$bvh.part" "$bvh"
  fi
  got=$(md5sum "$bvh" | cut -d' ' -f1)
  if [ "$got" != "$md5" ]; then
    echo "error: $bvh has MD5 $got, expected $md5 (a different file: delete it to download again)" >&2
    exit 1
  fi
}
