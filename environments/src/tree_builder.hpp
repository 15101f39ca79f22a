// Internal: an OcTree whose root can be created directly, so that trees can be assembled node by node
// (octomap exposes createNodeChild() but not root creation).
#pragma once

#include <octomap/OcTree.h>

namespace ctr::environments::detail {

class TreeBuilder : public octomap::OcTree {
 public:
  using octomap::OcTree::OcTree;
  /// Root node, created (as a leaf) if the tree is empty.
  octomap::OcTreeNode* makeRoot() {
    if (root == nullptr) {
      root = new octomap::OcTreeNode();
      ++tree_size;
      size_changed = true;
    }
    return root;
  }
};

}  // namespace ctr::environments::detail
