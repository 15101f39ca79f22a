// The contact results of a solve and the contact unknowns of a warm start (contact_events.hpp).
#include "contact_events.hpp"

namespace ctr::detail {

std::vector<ContactResult> contactResults(const Problem& P, const std::vector<double>& relative_twist,
                                          const std::vector<double>& moment, const Eigen::VectorXd& z, int first) {
  std::vector<ContactResult> results;
  results.reserve(P.contacts.size());
  for (std::size_t c = 0; c < P.contacts.size(); ++c) {
    const ActiveContact& ac = P.contacts[c];
    ContactResult cr;
    cr.site = ac.site;
    cr.condition = ac.condition;
    cr.relative_twist = relative_twist[c];
    cr.moment = moment[c];
    cr.torque = z[first + static_cast<int>(c)] * P.kt[ac.site.inner];
    results.push_back(cr);
  }
  return results;
}

void contactUnknownsFrom(const Problem& P, const std::vector<ContactResult>& contacts, Eigen::VectorXd& z, int first) {
  for (std::size_t c = 0; c < P.contacts.size(); ++c)
    for (const ContactResult& w : contacts)
      if (w.site == P.contacts[c].site) z[first + static_cast<int>(c)] = w.torque / P.kt[P.contacts[c].site.inner];
}

}  // namespace ctr::detail
