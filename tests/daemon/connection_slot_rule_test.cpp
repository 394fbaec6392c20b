// The connection-slot rule (docs/security.md "Connection slots") as pure functions: the
// last kReservedControlSlots of max_clients only for peers with the right to them, then
// kEstopOnlySlots connections that may send `estop` and nothing else.
#include <gtest/gtest.h>

#include "daemon/standcald/server.hpp"

using namespace standcal::daemon;

namespace {

Peer unix_peer_of(uid_t uid, gid_t gid, std::vector<gid_t> groups = {}) {
  Peer p;
  p.credentials_known = true;
  p.uid = uid;
  p.gid = gid;
  p.groups = std::move(groups);
  return p;
}

}  // namespace

TEST(ConnectionSlotRule, TheLastSlotsGoOnlyToPeersWithTheRightAndEstopOnlySlotsFollow) {
  const int max = 256;
  const int open = max - kReservedControlSlots;
  EXPECT_EQ(slot_for_new_client({open - 1, 0}, max, false), ClientSlot::ordinary);
  EXPECT_EQ(slot_for_new_client({open, 0}, max, false), ClientSlot::estop_only);
  EXPECT_EQ(slot_for_new_client({open, 0}, max, true), ClientSlot::reserved);
  EXPECT_EQ(slot_for_new_client({max - 1, 0}, max, true), ClientSlot::reserved);
  EXPECT_EQ(slot_for_new_client({max, 0}, max, true), ClientSlot::estop_only);
  EXPECT_EQ(slot_for_new_client({max, kEstopOnlySlots - 1}, max, false), ClientSlot::estop_only);
  EXPECT_EQ(slot_for_new_client({max, kEstopOnlySlots}, max, true), std::nullopt);
}

TEST(ConnectionSlotRule, RootTheDaemonsUserAndTheControlGroupMayUseReservedSlotsTcpNever) {
  AccessPolicy policy;
  policy.daemon_uid = 990;
  EXPECT_TRUE(may_use_reserved_slot(unix_peer_of(0, 0), policy));
  EXPECT_TRUE(may_use_reserved_slot(unix_peer_of(990, 990), policy));
  EXPECT_FALSE(may_use_reserved_slot(unix_peer_of(1000, 1000), policy))
      << "no control group: only root and daemon";
  policy.control_group = "operators";
  policy.control_gid = 4242;
  EXPECT_TRUE(may_use_reserved_slot(unix_peer_of(1000, 1000, {27, 4242}), policy));
  EXPECT_TRUE(may_use_reserved_slot(unix_peer_of(1000, 4242), policy));
  EXPECT_FALSE(may_use_reserved_slot(unix_peer_of(1000, 1000, {27}), policy));
  Peer unknown;
  EXPECT_FALSE(may_use_reserved_slot(unknown, policy));
  Peer tcp;
  tcp.tcp = true;
  tcp.token_accepted = true;
  EXPECT_FALSE(may_use_reserved_slot(tcp, policy))
      << "who holds the token is known only after auth";
}
