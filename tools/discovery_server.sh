#!/usr/bin/env bash
# Runs a Fast DDS discovery server (fast-discovery-server, Debian package fastdds-tools) for Cairn processes on
# one named network, bound to this host's one address in it and to nothing else (network safety: the server
# is a DDS participant too, and Fast DDS's defaults would listen on every interface).
#   discovery_server.sh --subnet CIDR [--port PORT]      (default port 11811)
# Clients: cairn_agent / cairn_base --link lan|radio --subnet CIDR --discovery-server ADDRESS:PORT, ADDRESS the
# one this prints. Runs in the foreground until SIGINT/SIGTERM.
set -euo pipefail
subnet="" port=11811
while [ $# -gt 0 ]; do
  case "$1" in
    --subnet) subnet="${2:-}"; shift 2 ;;
    --port) port="${2:-}"; shift 2 ;;
    *) echo "discovery_server: unknown argument '$1' (usage: --subnet CIDR [--port PORT])" >&2; exit 2 ;;
  esac
done
[[ "$subnet" =~ ^([0-9]{1,3}\.){3}[0-9]{1,3}/([0-9]|[12][0-9]|3[0-2])$ ]] ||
  { echo "discovery_server: --subnet '$subnet' must be an IPv4 CIDR, e.g. 10.77.0.0/24" >&2; exit 2; }
[[ "$port" =~ ^[0-9]{1,5}$ ]] && [ "$port" -ge 1 ] && [ "$port" -le 65535 ] ||
  { echo "discovery_server: --port '$port' must be in [1, 65535]" >&2; exit 2; }

to_int() { local IFS=.; read -r a b c d <<<"$1"; echo $(( (a << 24) | (b << 16) | (c << 8) | d )); }
net="${subnet%/*}" bits="${subnet#*/}"
mask=$(( bits == 0 ? 0 : (0xFFFFFFFF << (32 - bits)) & 0xFFFFFFFF ))
want=$(( $(to_int "$net") & mask ))
addresses=() seen=""
while read -r _ ifname _ cidr _; do
  address="${cidr%/*}"
  seen+="${seen:+, }$ifname $address"
  [ $(( $(to_int "$address") & mask )) -eq "$want" ] && addresses+=("$address")
done < <(ip -4 -o addr show)
if [ "${#addresses[@]}" -ne 1 ]; then
  echo "discovery_server: --subnet $subnet: this host has ${#addresses[@]} IPv4 addresses there, needs one (seen: $seen)" >&2
  exit 2
fi
address="${addresses[0]}"
xml="$(mktemp --suffix=.xml)"
trap 'rm -f "$xml"' EXIT
cat >"$xml" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <transport_descriptors>
      <transport_descriptor>
        <transport_id>cairn_udp</transport_id>
        <type>UDPv4</type>
        <interfaceWhiteList><address>$address</address></interfaceWhiteList>
      </transport_descriptor>
    </transport_descriptors>
    <participant profile_name="cairn_discovery_server" is_default_profile="true">
      <rtps>
        <prefix>44.53.00.5f.45.50.52.4f.53.49.4d.41</prefix>
        <useBuiltinTransports>false</useBuiltinTransports>
        <userTransports><transport_id>cairn_udp</transport_id></userTransports>
        <builtin>
          <discovery_config>
            <discoveryProtocol>SERVER</discoveryProtocol>
            <clientAnnouncementPeriod><sec>0</sec><nanosec>100000000</nanosec></clientAnnouncementPeriod>
          </discovery_config>
          <metatrafficUnicastLocatorList>
            <locator><udpv4><address>$address</address><port>$port</port></udpv4></locator>
          </metatrafficUnicastLocatorList>
        </builtin>
        <defaultUnicastLocatorList>
          <locator><udpv4><address>$address</address></udpv4></locator>
        </defaultUnicastLocatorList>
      </rtps>
    </participant>
  </profiles>
</dds>
XML
echo "discovery server on $address:$port (clients: --discovery-server $address:$port)"
fast-discovery-server -x "$xml" &
server=$!
trap 'kill -TERM "$server" 2>/dev/null; wait "$server" 2>/dev/null; rm -f "$xml"' EXIT INT TERM
wait "$server"
